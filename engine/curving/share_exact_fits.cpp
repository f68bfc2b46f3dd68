#include "engine/curving/share_exact_fits.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

LocalFit exact_surface_fit(std::shared_ptr<const ExactQuadric> surface, const LocalFit& fit, int p) {
  LocalFit F;
  F.surface = std::move(surface);
  F.o = fit.o;
  F.h = fit.h;
  F.n = F.surface->gradient(F.o).normalized();
  if (F.n.dot(fit.n) < 0) F.n = -F.n;
  tangent_frame(F.n, F.t1, F.t2);
  F.exact = true;
  F.degree = F.requested_degree = p;
  F.c = Eigen::VectorXd::Zero(fit_coefficients(p));
  F.pivot_ratio = 1;
  return F;
}

bool wedge_faces_on(const Mesh& mesh, const Wedges& W, int w, const ExactQuadric& Q, const ExactQuadricOptions& opt) {
  const double min_cos = std::cos(opt.max_normal_angle_deg * std::numbers::pi / 180.0);
  double side = 0;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d n = face_normal(mesh, f).normalized();
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d x = mesh.V.row(mesh.F(f, j)).transpose();
      if (!Q.contains(x)) return false;
      const double c = n.dot(Q.gradient(x).normalized());
      if (side == 0) side = c > 0 ? 1 : -1;
      if (!(side * c >= min_cos)) return false;
    }
  }
  return side != 0;
}

namespace {

/// Wedge w has no exact fit (nor a cone model), and its faces turn from its fit's normal by more
/// than min_turn_deg, or it is one-sided: where fit_wedge tries its own. Below, its height fit is
/// closer than a quadric fitted to rounding (a 20k-triangle ellipsoid's flatter half took its
/// neighbours' quadrics: P4 1.9e-8 -> 7.0e-9 from 5k triangles, not 6e-10).
bool may_take(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits, int w, const ExactQuadricOptions& opt) {
  return !fits[w].exact && !fits[w].apex && !W.is_cone(W.wedge_vertex[w]) &&
         (W.one_sided(w) || wedge_turn_deg(mesh, W, w, fits[w].n) > opt.min_turn_deg);
}

/// The exact surface tangent at v: the first exact fit of a corner of a face at v outside wedge
/// w that passes through v (null if none); its normal there in n.
const ExactQuadric* tangent_normal(const Mesh& mesh, const Topology& T, const Wedges& W,
                                   const std::vector<LocalFit>& fits, int w, int v, Eigen::Vector3d& n) {
  const Eigen::Vector3d x = mesh.V.row(v).transpose();
  for (auto [b, e] = T.faces_of(v); b != e; ++b) {
    int j = 0;
    while (mesh.F(*b, j) != v) ++j;
    if (W.corner_wedge(*b, j) == w) continue;
    for (int k = 0; k < 3; ++k) {
      const LocalFit& F = fits[W.corner_wedge(*b, k)];
      if (F.exact && F.surface->contains(x)) {
        n = F.surface->gradient(x).normalized();
        return n.allFinite() ? F.surface.get() : nullptr;
      }
    }
  }
  return nullptr;
}

/// Wedge w's quadric through its faces' corners, tangent to the exact surfaces through them
/// (fit_tangent_quadric; valid false where none is determined).
ExactQuadric tangent_wedge_quadric(const Mesh& mesh, const Topology& T, const Wedges& W,
                                   const std::vector<LocalFit>& fits, int w, const ExactQuadricOptions& opt) {
  std::vector<int> verts;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i)
    for (int j = 0; j < 3; ++j) verts.push_back(mesh.F(W.wedge_faces[i], j));
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  Eigen::MatrixXd P(verts.size(), 3), X(verts.size(), 3), N(verts.size(), 3);
  int m = 0;
  std::vector<const ExactQuadric*> tangent;
  for (size_t i = 0; i < verts.size(); ++i) {
    P.row(i) = mesh.V.row(verts[i]);
    Eigen::Vector3d n;
    if (const ExactQuadric* S = tangent_normal(mesh, T, W, fits, w, verts[i], n)) {
      X.row(m) = P.row(i), N.row(m++) = n.transpose();
      if (std::find(tangent.begin(), tangent.end(), S) == tangent.end()) tangent.push_back(S);
    }
  }
  // Some corner must lie clearly off every surface it is tangent to: else the faces are on those
  // surfaces (needles whose normals disagree with them), and a quadric tangent to them at a few
  // close points only osculates them (a marching-tetrahedra torus: P4 2.5e-6 -> 3.9e-4).
  auto clearly_off = [&](Eigen::Index i) {
    return std::all_of(tangent.begin(), tangent.end(), [&](const ExactQuadric* S) {
      return S->distance(P.row(i).transpose()) >= opt.clear_factor * S->tolerance;
    });
  };
  ExactQuadric Q;
  bool off = false;
  for (Eigen::Index i = 0; i < P.rows() && !off; ++i) off = clearly_off(i);
  if (m < 2 || !off) return Q;
  Q = fit_tangent_quadric(P, X.topRows(m), N.topRows(m));
  Q.tolerance = opt.relative_tolerance() * P.rowwise().norm().maxCoeff();
  Q.valid = Q.valid && Q.max_residual <= Q.tolerance && Q.runner_up >= opt.unique * Q.tolerance && !plane_pair(Q) &&
            wedge_faces_on(mesh, W, w, Q, opt);
  return Q;
}

}  // namespace

long long tangent_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const ExactQuadricOptions& opt,
                             std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  long long fitted = 0;
  std::vector<std::shared_ptr<const ExactQuadric>> found(nw);
  // Nothing to be tangent to (scans, smooth meshes): no pass.
  bool changed = std::any_of(fits.begin(), fits.end(), [](const LocalFit& F) { return F.exact; });
  while (changed) {
    tbb::parallel_for(tbb::blocked_range<int>(0, nw, 64), [&](const tbb::blocked_range<int>& r) {
      for (int w = r.begin(); w < r.end(); ++w) {
        found[w].reset();
        if (!may_take(mesh, W, fits, w, opt)) continue;
        ExactQuadric Q = tangent_wedge_quadric(mesh, T, W, fits, w, opt);
        if (Q.valid) found[w] = std::make_shared<const ExactQuadric>(std::move(Q));
      }
    });
    changed = false;
    for (int w = 0; w < nw; ++w)
      if (found[w]) {
        fits[w] = exact_surface_fit(found[w], fits[w], fits[w].requested_degree);
        changed = true;
        ++fitted;
      }
    if (changed) fitted += share_exact_fits(mesh, W, opt, fits);
  }
  return fitted;
}

long long share_exact_fits(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt, std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  long long shared = 0;
  std::vector<int> from(nw);
  for (bool changed = true; changed;) {
    std::fill(from.begin(), from.end(), -1);
    tbb::parallel_for(tbb::blocked_range<int>(0, nw, 256), [&](const tbb::blocked_range<int>& r) {
      for (int w = r.begin(); w < r.end(); ++w) {
        if (!may_take(mesh, W, fits, w, opt)) continue;
        for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1] && from[w] < 0; ++i)
          for (int j = 0; j < 3 && from[w] < 0; ++j) {
            const int u = W.corner_wedge(W.wedge_faces[i], j);
            if (u != w && fits[u].exact && wedge_faces_on(mesh, W, w, *fits[u].surface, opt)) from[w] = u;
          }
      }
    });
    changed = false;
    for (int w = 0; w < nw; ++w)
      if (from[w] >= 0) {
        fits[w] = exact_surface_fit(fits[from[w]].surface, fits[w], fits[w].requested_degree);
        changed = true;
        ++shared;
      }
  }
  return shared;
}

}  // namespace hocurve
