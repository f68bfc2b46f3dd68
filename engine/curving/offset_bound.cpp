#include "engine/curving/offset_bound.hpp"

#include "engine/highorder/reference_nodes.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace hocurve {
namespace {

/// Normal of a height fit's surface at its vertex, by central differences of its projection.
Eigen::Vector3d fit_normal(const LocalFit& fit) {
  // A cone's apex has no tangent plane; an exact surface is confirmed by its data to rounding and
  // is not second-guessed (zero: unbounded).
  if (fit.apex || fit.exact) return Eigen::Vector3d::Zero();
  if (fit.identity) return fit.n;
  const double eps = 1e-2 * fit.h;
  const Eigen::Vector3d du = fit.project(fit.o + eps * fit.t1) - fit.project(fit.o - eps * fit.t1);
  const Eigen::Vector3d dv = fit.project(fit.o + eps * fit.t2) - fit.project(fit.o - eps * fit.t2);
  const Eigen::Vector3d n = du.cross(dv);
  if (!(n.norm() > 0) || !n.allFinite()) return fit.n;
  return (n.dot(fit.n) < 0 ? -n : n).normalized();
}

/// The allowed offset along a normal for a chord of length L whose largest sine against the
/// corners' tangent planes is s (negative s: a corner without a tangent plane, unbounded).
double allowed(double L, double s, const OffsetBoundOptions& opt) {
  return s < 0 ? INFINITY : opt.factor * 0.25 * L * s + opt.slack * L;
}

}  // namespace

std::vector<Eigen::Vector3d> wedge_normals(const Wedges& W, const std::vector<LocalFit>& fits) {
  std::vector<Eigen::Vector3d> n(W.num_wedges(), Eigen::Vector3d::Zero());
  tbb::parallel_for(0, W.num_wedges(), [&](int w) {
    if (w < static_cast<int>(fits.size())) n[w] = fit_normal(fits[w]);
  });
  return n;
}

OffsetBoundResult bound_offsets(const Mesh& mesh, const Topology& T, const Wedges& W,
                                const std::vector<LocalFit>& fits, const std::vector<const LocalFit*>* face_fits,
                                HighOrderMesh& hm, const OffsetBoundOptions& opt) {
  OffsetBoundResult R;
  const int p = hm.order, nf = mesh.num_faces(), ne = T.num_edges();
  if (!opt.enabled || p < 2) return R;
  const std::vector<Eigen::Vector3d> wn = wedge_normals(W, fits);
  auto corner_normal = [&](int f, int j) -> const Eigen::Vector3d& { return wn[W.corner_wedge(f, j)]; };
  const Eigen::VectorXd line = line_reference_nodes(p, hm.distribution);
  const Eigen::MatrixXd tri = triangle_reference_nodes(p, hm.distribution);
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  // What exact surfaces placed (a face on one, an edge of such a face, a corner on one) is confirmed
  // by its data, to rounding: not second-guessed (a tee of two cylinders at Gmsh's sizes, its
  // saddle curve's edges between exact corners bounded: P4 6e-5 -> 1.9e-2).
  auto on_exact = [&](int f) { return face_fits && (*face_fits)[f] && (*face_fits)[f]->exact; };
  auto on_exact_surface = [&](int e) {
    for (int f : T.edge_faces[e])
      if (on_exact(f)) return true;
    return false;
  };

  // Edges: for each face side, the offsets along that side's mean corner normal.
  std::vector<double> edge_scale(ne, 1.0);
  tbb::parallel_for(0, ne, [&](int e) {
    const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)), b = mesh.V.row(T.E(e, 1));
    const double L = (b - a).norm();
    if (!(L > 0)) return;
    const Eigen::Vector3d u = (b - a) / L;
    double scale = 1;
    if (on_exact_surface(e)) return;
    for (int f : T.edge_faces[e]) {
      Eigen::Vector3d na = Eigen::Vector3d::Zero(), nb = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) {
        if (mesh.F(f, j) == T.E(e, 0)) na = corner_normal(f, j);
        if (mesh.F(f, j) == T.E(e, 1)) nb = corner_normal(f, j);
      }
      const bool defined = na.squaredNorm() > 0 && nb.squaredNorm() > 0;
      const double s = defined ? std::max(std::abs(na.dot(u)), std::abs(nb.dot(u))) : -1;
      const Eigen::Vector3d m = (na + nb).normalized();
      const double bound = allowed(L, s, opt);
      for (int k = 1; k < p && std::isfinite(bound); ++k) {
        const Eigen::Vector3d x = (1 - line[k]) * a + line[k] * b;
        const double off = std::abs(m.dot(hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1).transpose() - x));
        if (off > bound) scale = std::min(scale, bound / off);
      }
    }
    edge_scale[e] = scale;
  });

  // Faces: interior offsets along the corners' mean normal, against the corners' tilt from the
  // face's plane; at most the face's edges' scale, so the interior follows its sides.
  std::vector<double> face_scale(nf, 1.0);
  if (npf > 0)
    tbb::parallel_for(0, nf, [&](int f) {
      Eigen::Matrix3d P;
      for (int j = 0; j < 3; ++j) P.row(j) = mesh.V.row(mesh.F(f, j));
      const Eigen::Vector3d fn = (P.row(1) - P.row(0)).cross(P.row(2) - P.row(0)).transpose();
      double scale = std::min({edge_scale[T.FE(f, 0)], edge_scale[T.FE(f, 1)], edge_scale[T.FE(f, 2)]});
      if (!(fn.norm() > 0) || on_exact(f)) {
        face_scale[f] = scale;
        return;
      }
      const Eigen::Vector3d nface = fn.normalized();
      double s = 0, D = 0;
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d n = corner_normal(f, j);
        if (!(n.squaredNorm() > 0)) s = -1;
        if (s >= 0) s = std::max(s, n.cross(nface).norm());
        m += n;
        D = std::max(D, (P.row((j + 1) % 3) - P.row(j)).norm());
      }
      const double bound = allowed(D, s, opt);
      if (std::isfinite(bound) && m.norm() > 0) {
        m.normalize();
        for (int k = 0; k < npf; ++k) {
          const double v1 = tri(3 * p + k, 0), v2 = tri(3 * p + k, 1);
          const Eigen::Vector3d x = (1 - v1 - v2) * P.row(0) + v1 * P.row(1) + v2 * P.row(2);
          const double off =
              std::abs(m.dot(hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k).transpose() - x));
          if (off > bound) scale = std::min(scale, bound / off);
        }
      }
      face_scale[f] = scale;
    });

  // Apply: straight + scale x offset.
  R.face.assign(nf, 0);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) R.face[f] = R.face[f] || face_scale[f] < 1 || edge_scale[T.FE(f, j)] < 1;
  for (int e = 0; e < ne; ++e) {
    if (edge_scale[e] >= 1) continue;
    ++R.edges;
    R.min_scale = std::min(R.min_scale, edge_scale[e]);
    const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)), b = mesh.V.row(T.E(e, 1));
    for (int k = 1; k < p; ++k) {
      const Eigen::Vector3d x = (1 - line[k]) * a + line[k] * b;
      auto row = hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1);
      row = (x + edge_scale[e] * (row.transpose() - x)).transpose();
    }
  }
  for (int f = 0; f < nf; ++f) {
    if (face_scale[f] >= 1 || npf == 0) continue;
    ++R.faces;
    R.min_scale = std::min(R.min_scale, face_scale[f]);
    for (int k = 0; k < npf; ++k) {
      const double v1 = tri(3 * p + k, 0), v2 = tri(3 * p + k, 1);
      const Eigen::Vector3d x = (1 - v1 - v2) * mesh.V.row(mesh.F(f, 0)).transpose() +
                                v1 * mesh.V.row(mesh.F(f, 1)).transpose() + v2 * mesh.V.row(mesh.F(f, 2)).transpose();
      auto row = hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k);
      row = (x + face_scale[f] * (row.transpose() - x)).transpose();
    }
  }
  return R;
}

}  // namespace hocurve
