#include "engine/coarse/dense_surface.hpp"

#include "engine/core/stopwatch.hpp"
#include "engine/curving/band_fit.hpp"
#include "engine/curving/place_nodes.hpp"
#include "engine/curving/support_points.hpp"
#include "engine/curving/uniformity.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace hocurve {

DenseSurface build_dense_surface(const Mesh& fine, const DenseSurfaceOptions& opt) {
  const auto t0 = Clock::now();
  DenseSurface S;
  S.mesh = &fine;
  S.T = build_topology(fine.F, fine.num_vertices());
  S.features = detect_features(fine, S.T, opt.features);
  S.W = build_wedges(fine, S.T, S.features.edge_feature, S.features.vertex_cone);
  SupportPoints support;
  if (opt.support && !check_uniformity(fine, S.T).uniform) {
    support = sample_support(fine);
    S.support_used = true;
  }
  S.fits = fit_wedges(fine, S.T, S.W, opt.degree, S.support_used ? &support : nullptr, opt.fit);
  refit_band_wedges(fine, S.T, S.W, S.features, opt.degree, opt.fit, S.fits.fits);  // as curve_mesh does
  S.planar_anchor = planar_patch_faces(fine, S.T, opt.planar);
  S.long_edges = opt.long_edges;
  if (smooth_surface(S.features, S.T, S.planar_anchor, S.long_edges)) S.long_edges.ratio = 0;
  S.long_face = long_edges(fine, S.T, S.W, S.fits.fits, S.long_edges).face;
  S.curves = fit_feature_curves(fine, S.T, S.features, opt.degree, opt.fit);
  S.max_lift = opt.max_lift;
  S.seconds = seconds_since(t0);
  return S;
}

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                          Eigen::Vector3d& bc) {
  // Voronoi regions of the vertices, then of the edges, else the interior.
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = x - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return bc = {1, 0, 0}, a;
  const Eigen::Vector3d bp = x - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bc = {0, 1, 0}, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    bc = {1 - v, v, 0};
    return a + v * ab;
  }
  const Eigen::Vector3d cp = x - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return bc = {0, 0, 1}, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    bc = {1 - w, 0, w};
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    bc = {0, 1 - w, w};
    return b + w * (c - b);
  }
  const double sum = va + vb + vc;
  if (!(sum > 0)) {  // degenerate triangle: nearest of the three vertices
    const double da = (x - a).squaredNorm(), db = (x - b).squaredNorm(), dc = (x - c).squaredNorm();
    if (da <= db && da <= dc) return bc = {1, 0, 0}, a;
    if (db <= dc) return bc = {0, 1, 0}, b;
    return bc = {0, 0, 1}, c;
  }
  const double v = vb / sum, w = vc / sum;
  bc = {1 - v - w, v, w};
  return a + v * ab + w * ac;
}

namespace {

double face_distance(const Mesh& m, int f, const Eigen::Vector3d& x, Eigen::Vector3d& bc, Eigen::Vector3d& q) {
  q = closest_point_on_triangle(x, m.V.row(m.F(f, 0)).transpose(), m.V.row(m.F(f, 1)).transpose(),
                                m.V.row(m.F(f, 2)).transpose(), bc);
  return (q - x).squaredNorm();
}

double segment_distance(const Mesh& m, const Topology& T, int e, const Eigen::Vector3d& x, double& t,
                        Eigen::Vector3d& q) {
  const Eigen::Vector3d a = m.V.row(T.E(e, 0)).transpose(), b = m.V.row(T.E(e, 1)).transpose();
  const double l2 = (b - a).squaredNorm();
  t = l2 > 0 ? std::clamp((x - a).dot(b - a) / l2, 0.0, 1.0) : 0.0;
  q = a + t * (b - a);
  return (q - x).squaredNorm();
}

/// lifted, moved back toward linear so that it lies at most max_lift x h from it.
Eigen::Vector3d capped_lift(const Eigen::Vector3d& linear, const Eigen::Vector3d& lifted, double h, double max_lift) {
  const double d = (lifted - linear).norm();
  if (!(d <= max_lift * h)) return d > 0 && std::isfinite(d) ? Eigen::Vector3d(linear + (lifted - linear) * (max_lift * h / d)) : linear;
  return lifted;
}

double mean_edge(const Mesh& m, int f) {
  const Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = m.V.row(m.F(f, 1)).transpose(),
                        c = m.V.row(m.F(f, 2)).transpose();
  return ((a - b).norm() + (b - c).norm() + (c - a).norm()) / 3;
}

/// The fitted surface's point for the point `linear` (barycentric bc) of dense face f: the capped
/// lift of the fits' blend, or linear itself on a flat CAD face (planar_patch_faces).
Eigen::Vector3d surface_point(const DenseSurface& S, int f, const Eigen::Vector3d& bc, const Eigen::Vector3d& linear) {
  if (!S.planar_anchor.empty() && S.planar_anchor[f] >= 0) return linear;
  if (!S.long_face.empty() && S.long_face[f])
    return capped_lift(linear, long_face_point(*S.mesh, S.W, f, bc, S.long_edges), mean_edge(*S.mesh, f), S.max_lift);
  return capped_lift(linear, blend_point(*S.mesh, S.W, S.fits.fits, f, bc), mean_edge(*S.mesh, f), S.max_lift);
}

}  // namespace

DenseProjection project_to_dense_surface(const DenseSurface& S, int f, const Eigen::Vector3d& x, int max_steps) {
  const Mesh& m = *S.mesh;
  DenseProjection P;
  Eigen::Vector3d bc, q;
  double d = face_distance(m, f, x, bc, q);
  // Greedy descent: the faces of the current face's corner wedges are its neighbours (they
  // never cross a feature edge, and they reach past vertices where distances tie).
  for (; P.steps < max_steps; ++P.steps) {
    int best = -1;
    double bd = d;
    Eigen::Vector3d bbc, bq;
    for (int j = 0; j < 3; ++j) {
      const int w = S.W.corner_wedge(f, j);
      for (int i = S.W.wedge_start[w]; i < S.W.wedge_start[w + 1]; ++i) {
        const int g = S.W.wedge_faces[i];
        if (g == f) continue;
        Eigen::Vector3d gbc, gq;
        const double gd = face_distance(m, g, x, gbc, gq);
        if (gd < bd || (gd == bd && best >= 0 && g < best)) bd = gd, best = g, bbc = gbc, bq = gq;
      }
    }
    if (best < 0 || !(bd < d * (1 - 1e-12))) break;
    f = best, d = bd, bc = bbc, q = bq;
  }
  P.face = f;
  P.bary = bc;
  P.linear = q;
  P.lifted = surface_point(S, f, bc, q);
  return P;
}

DenseProjection project_along_dense_surface(const DenseSurface& S, int f, const Eigen::Vector3d& x,
                                            const Eigen::Vector3d& d, double max_t, bool& ok, int max_steps) {
  const Mesh& m = *S.mesh;
  const auto& ef = S.features.edge_feature;
  DenseProjection P;
  ok = false;
  const int start = f;
  for (; P.steps < max_steps; ++P.steps) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = m.V.row(m.F(f, 1)).transpose(),
                          c = m.V.row(m.F(f, 2)).transpose();
    const Eigen::Vector3d nf = (b - a).cross(c - a);
    const double n2 = nf.squaredNorm(), den = d.dot(nf);
    if (!(n2 > 0) || !(std::abs(den) > 1e-8 * std::sqrt(n2))) break;
    const double t = (a - x).dot(nf) / den;
    const Eigen::Vector3d y = x + t * d;
    // Barycentrics of y in the plane of the face.
    Eigen::Vector3d bc((c - b).cross(y - b).dot(nf) / n2, (a - c).cross(y - c).dot(nf) / n2, 0);
    bc[2] = 1 - bc[0] - bc[1];
    int j = 0;
    for (int k = 1; k < 3; ++k)
      if (bc[k] < bc[j]) j = k;
    if (bc[j] >= -1e-12) {
      if (!(std::abs(t) <= max_t)) break;
      bc = bc.cwiseMax(0.0);
      bc /= bc.sum();
      P.face = f;
      P.bary = bc;
      P.linear = bc[0] * a + bc[1] * b + bc[2] * c;
      P.lifted = surface_point(S, f, bc, P.linear);
      ok = true;
      return P;
    }
    // Cross the edge opposite corner j (edge (j+1)%3 joins corners j+1 and j+2).
    const int e = S.T.FE(f, (j + 1) % 3);
    const auto& faces = S.T.edge_faces[e];
    if ((!ef.empty() && ef[e]) || faces.size() != 2) break;
    f = faces[0] == f ? faces[1] : faces[0];
  }
  DenseProjection Q = project_to_dense_surface(S, start, x);
  Q.steps += P.steps;
  return Q;
}

DenseProjection project_to_dense_curve(const DenseSurface& S, int f, const Eigen::Vector3d& x, int max_steps) {
  const Mesh& m = *S.mesh;
  const Topology& T = S.T;
  const auto& ef = S.features.edge_feature;
  if (ef.empty() || S.curves.fits.empty()) return project_to_dense_surface(S, f, x, max_steps);
  // Candidate feature edges: around the start face's vertices, then a few face rings further.
  int best = -1;
  double bd = std::numeric_limits<double>::infinity(), bt = 0;
  Eigen::Vector3d bq;
  std::vector<int> faces = {f}, next;
  std::vector<char> seen_face;  // allocated lazily: most queries end at ring 0
  for (int ring = 0; ring < 4 && best < 0; ++ring) {
    for (int g : faces)
      for (int j = 0; j < 3; ++j) {
        auto [b, e] = T.edges_of(m.F(g, j));
        for (const int* it = b; it != e; ++it) {
          if (!ef[*it]) continue;
          double t;
          Eigen::Vector3d q;
          const double d = segment_distance(m, T, *it, x, t, q);
          if (d < bd || (d == bd && *it < best)) bd = d, best = *it, bt = t, bq = q;
        }
      }
    if (best >= 0) break;
    if (seen_face.empty()) seen_face.assign(m.num_faces(), 0);
    next.clear();
    for (int g : faces) seen_face[g] = 1;
    for (int g : faces)
      for (int j = 0; j < 3; ++j) {
        auto [b, e] = T.faces_of(m.F(g, j));
        for (const int* it = b; it != e; ++it)
          if (!seen_face[*it]) seen_face[*it] = 1, next.push_back(*it);
      }
    faces.swap(next);
  }
  if (best < 0) return project_to_dense_surface(S, f, x, max_steps);
  DenseProjection P;
  for (; P.steps < max_steps; ++P.steps) {
    int nb = -1;
    double nd = bd, nt = 0;
    Eigen::Vector3d nq;
    for (int k = 0; k < 2; ++k) {
      auto [b, e] = T.edges_of(T.E(best, k));
      for (const int* it = b; it != e; ++it) {
        if (*it == best || !ef[*it]) continue;
        double t;
        Eigen::Vector3d q;
        const double d = segment_distance(m, T, *it, x, t, q);
        if (d < nd || (d == nd && nb >= 0 && *it < nb)) nd = d, nb = *it, nt = t, nq = q;
      }
    }
    if (nb < 0 || !(nd < bd * (1 - 1e-12))) break;
    best = nb, bd = nd, bt = nt, bq = nq;
  }
  P.edge = best;
  P.t = bt;
  P.face = T.edge_faces[best].empty() ? f : T.edge_faces[best][0];
  P.linear = bq;
  P.lifted = capped_lift(bq, curve_edge_point(m, T, S.curves, best, bt),
                         (m.V.row(T.E(best, 0)) - m.V.row(T.E(best, 1))).norm(), S.max_lift);
  return P;
}

}  // namespace hocurve
