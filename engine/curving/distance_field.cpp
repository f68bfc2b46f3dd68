#include "engine/curving/distance_field.hpp"

#include "engine/core/error.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <queue>
#include <string>
#include <utility>
#include <vector>

namespace hocurve {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// First-order fast-marching update of vertex c from accepted a, b (values ta, tb): the planar
/// front T(x) = t + g.(x - c), |g| = 1, through (a, ta) and (b, tb). Returns +inf when the
/// characteristic reaching c does not come through segment ab (then only edge updates apply).
double triangle_update(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, double ta,
                       double tb) {
  Eigen::Matrix<double, 3, 2> X;
  X.col(0) = a - c;
  X.col(1) = b - c;
  const Eigen::Matrix2d G = X.transpose() * X;
  const double det = G.determinant();
  if (!(det > 1e-14 * G(0, 0) * G(1, 1))) return kInf;  // degenerate triangle
  const Eigen::Matrix2d Q = G.inverse();
  const Eigen::Vector2d T(ta, tb), one(1, 1);
  // (T - t 1)^T Q (T - t 1) = 1, quadratic in t; the larger root is the arrival time.
  const double qa = one.dot(Q * one), qb = one.dot(Q * T), qc = T.dot(Q * T) - 1.0;
  const double disc = qb * qb - qa * qc;
  if (disc < 0) return kInf;
  const double t = (qb + std::sqrt(disc)) / qa;
  // Upwind: -g = X(-Q delta) must lie in the cone of (a-c, b-c), and t must not undercut a, b.
  const Eigen::Vector2d w = Q * (T - t * one);
  if (w[0] > 0 || w[1] > 0) return kInf;
  if (t < std::max(ta, tb)) return kInf;
  return t;
}

/// A virtual triangle (C, x, y) for an obtuse corner C: two mesh vertices unfolded into the
/// plane of the corner's face (frame: C = 0, A = (|CA|, 0), B above), with every ray from C
/// between them crossing the unfolded strip. (Kimmel & Sethian's unfolding, keeping each
/// strip triangle met on the way, not only the final split of the corner.)
struct VirtualPair {
  int x = -1, y = -1;
  Eigen::Vector2d X, Y;
};

/// 2D frame of corner c of face f: A on +x, B in the upper half-plane.
void corner_frame(const Mesh& mesh, int f, int k, Eigen::Vector2d& A, Eigen::Vector2d& B) {
  const Eigen::Vector3d c = mesh.V.row(mesh.F(f, k)), a = mesh.V.row(mesh.F(f, (k + 1) % 3)),
                        b = mesh.V.row(mesh.F(f, (k + 2) % 3));
  const double la = (a - c).norm();
  const Eigen::Vector3d ex = (a - c) / la;
  const double bx = (b - c).dot(ex);
  A = {la, 0};
  B = {bx, std::sqrt(std::max(0.0, (b - c).squaredNorm() - bx * bx))};
}

/// Unfolds the faces across the edge opposite the obtuse corner k of face f, toward the section
/// of directions that splits the corner into two non-obtuse angles, and appends the virtual
/// triangles met on the way to `out`. Stops in that section, at a boundary or non-manifold
/// edge, or after a few steps.
void unfold_obtuse(const Mesh& mesh, const Topology& T, int f, int k, std::vector<VirtualPair>& out) {
  Eigen::Vector2d A, B;
  corner_frame(mesh, f, k, A, B);
  const double theta = std::atan2(B.y(), B.x());
  const double lo = theta - std::numbers::pi / 2, hi = std::numbers::pi / 2;  // the acute section
  double cone_lo = 0, cone_hi = theta;  // rays from C that stayed inside the strip so far
  int p = mesh.F(f, (k + 1) % 3), q = mesh.F(f, (k + 2) % 3), face = f;
  Eigen::Vector2d P = A, Q = B;
  for (int step = 0; step < 12; ++step) {
    int e = -1;
    for (int j = 0; j < 3; ++j) {
      const int u = mesh.F(face, j), w = mesh.F(face, (j + 1) % 3);
      if ((u == p && w == q) || (u == q && w == p)) e = T.FE(face, j);
    }
    if (e < 0 || T.edge_faces[e].size() != 2) return;
    const int g = T.edge_faces[e][0] == face ? T.edge_faces[e][1] : T.edge_faces[e][0];
    int r = -1;
    for (int j = 0; j < 3; ++j)
      if (mesh.F(g, j) != p && mesh.F(g, j) != q) r = mesh.F(g, j);
    if (r < 0) return;
    // Place r across PQ (away from C) with its true distances to p and q.
    const Eigen::Vector3d vp = mesh.V.row(p), vq = mesh.V.row(q), vr = mesh.V.row(r);
    const double lpq = (vq - vp).norm();
    const Eigen::Vector2d d = Q - P;
    if (!(lpq > 0) || !(d.norm() > 0)) return;
    const Eigen::Vector2d ux = d / d.norm(), uy(-ux.y(), ux.x());
    const double x = (vr - vp).dot(vq - vp) / lpq;
    const double y = std::sqrt(std::max(0.0, (vr - vp).squaredNorm() - x * x));
    const double side = (-P).dot(uy) > 0 ? -1.0 : 1.0;  // C = origin lies on the other side
    const Eigen::Vector2d R = P + x * ux + side * y * uy;
    const double phi = std::atan2(R.y(), R.x());
    if (phi > cone_lo && phi < cone_hi) {
      out.push_back({p, r, P, R});
      out.push_back({r, q, R, Q});
    }
    if (phi >= lo && phi <= hi) return;
    if (phi < lo) p = r, P = R, cone_lo = std::max(cone_lo, phi);  // the section lies toward CB
    else q = r, Q = R, cone_hi = std::min(cone_hi, phi);
    if (cone_lo >= cone_hi) return;
    face = g;
  }
}

}  // namespace

DistanceField feature_distance(const Mesh& mesh, const Topology& T, const Features& features,
                               const DistanceOptions& opt) {
  const int nv = mesh.num_vertices(), nf = mesh.num_faces();
  if (T.FE.rows() != nf || static_cast<int>(T.vf_start.size()) != nv + 1)
    throw InputError("feature distance", "topology was built for another mesh");
  if (!features.vertex_feature.empty() && static_cast<int>(features.vertex_feature.size()) != nv)
    throw InputError("feature distance", "features have " + std::to_string(features.vertex_feature.size()) +
                                             " vertex marks for " + std::to_string(nv) + " vertices");
  DistanceField D;
  D.distance = Eigen::VectorXd::Constant(nv, kInf);
  using Item = std::pair<double, int>;  // (distance, vertex): ties pop the lower vertex first
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  for (int v = 0; v < static_cast<int>(features.vertex_feature.size()); ++v)
    if (features.vertex_feature[v]) {
      D.distance[v] = 0.0;
      heap.push({0.0, v});
      ++D.sources;
    }
  auto pos = [&](int v) -> Eigen::Vector3d { return mesh.V.row(v).transpose(); };

  // Obtuse corners get virtual triangles by unfolding; `dependents` lists, per vertex, the
  // corners (3f+k) whose virtual triangles use it, so they are updated when it is accepted.
  std::vector<VirtualPair> pairs;
  std::vector<int> pair_start;  // corner 3f+k -> its virtual triangles (CSR)
  std::vector<std::vector<int>> dependents;
  if (opt.fast_marching) {
    pair_start.assign(3 * static_cast<size_t>(nf) + 1, 0);
    dependents.resize(nv);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d c = pos(mesh.F(f, k)), a = pos(mesh.F(f, (k + 1) % 3)), b = pos(mesh.F(f, (k + 2) % 3));
        const size_t first = pairs.size();
        if ((a - c).dot(b - c) < 0) unfold_obtuse(mesh, T, f, k, pairs);
        pair_start[3 * f + k + 1] = static_cast<int>(pairs.size());
        for (size_t i = first; i < pairs.size(); ++i)
          for (int w : {pairs[i].x, pairs[i].y})
            if (dependents[w].empty() || dependents[w].back() != 3 * f + k) dependents[w].push_back(3 * f + k);
      }
  }

  std::vector<char> done(nv, 0);
  auto relax = [&](int x, double t) {
    if (t < D.distance[x]) {
      D.distance[x] = t;
      heap.push({t, x});
    }
  };
  // When v is accepted, only the updates that involve v are new: every other combination of
  // accepted vertices was tried when its last member was accepted.
  while (!heap.empty()) {
    const auto [tv, v] = heap.top();
    heap.pop();
    if (done[v] || tv > D.distance[v]) continue;  // stale entry
    done[v] = 1;
    auto [eb, ee] = T.edges_of(v);
    for (const int* it = eb; it != ee; ++it) {
      const int x = T.other(*it, v);
      if (done[x]) continue;
      double best = tv + (pos(v) - pos(x)).norm();
      if (opt.fast_marching)
        for (const int f : T.edge_faces[*it]) {  // triangles (x, v, third) with third accepted
          int third = -1;
          for (int j = 0; j < 3; ++j)
            if (mesh.F(f, j) != x && mesh.F(f, j) != v) third = mesh.F(f, j);
          if (third >= 0 && done[third])
            best = std::min(best, triangle_update(pos(v), pos(third), pos(x), tv, D.distance[third]));
        }
      relax(x, best);
    }
    if (!opt.fast_marching) continue;
    for (const int c : dependents[v]) {  // virtual triangles of obtuse corners that use v
      const int x = mesh.F(c / 3, c % 3);
      if (done[x]) continue;
      double best = kInf;
      for (int i = pair_start[c]; i < pair_start[c + 1]; ++i) {
        const VirtualPair& vp = pairs[i];
        if (!((vp.x == v && done[vp.y]) || (vp.y == v && done[vp.x]))) continue;
        const Eigen::Vector3d X3(vp.X.x(), vp.X.y(), 0), Y3(vp.Y.x(), vp.Y.y(), 0);
        best = std::min(best, triangle_update(X3, Y3, Eigen::Vector3d::Zero(), D.distance[vp.x], D.distance[vp.y]));
      }
      relax(x, best);
    }
  }
  for (int v = 0; v < nv; ++v) {
    if (std::isfinite(D.distance[v]))
      D.max_finite = std::max(D.max_finite, D.distance[v]);
    else
      ++D.unreachable;
  }
  return D;
}

}  // namespace hocurve
