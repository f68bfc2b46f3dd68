#include "engine/curving/distance_field.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
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

}  // namespace

DistanceField feature_distance(const Mesh& mesh, const Topology& T, const Features& features,
                               const DistanceOptions& opt) {
  const int nv = mesh.num_vertices();
  DistanceField D;
  D.distance = Eigen::VectorXd::Constant(nv, kInf);
  using Item = std::pair<double, int>;  // (distance, vertex): ties pop the lower vertex first
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  for (int v = 0; v < nv && v < static_cast<int>(features.vertex_feature.size()); ++v)
    if (features.vertex_feature[v]) {
      D.distance[v] = 0.0;
      heap.push({0.0, v});
      ++D.sources;
    }
  std::vector<char> done(nv, 0);
  auto pos = [&](int v) -> Eigen::Vector3d { return mesh.V.row(v).transpose(); };
  auto relax = [&](int x, double t) {
    if (t < D.distance[x]) {
      D.distance[x] = t;
      heap.push({t, x});
    }
  };
  while (!heap.empty()) {
    const auto [d, v] = heap.top();
    heap.pop();
    if (done[v] || d > D.distance[v]) continue;  // stale entry
    done[v] = 1;
    // Edge updates (Dijkstra part; also the fallback of fast marching).
    auto [eb, ee] = T.edges_of(v);
    for (const int* it = eb; it != ee; ++it) {
      const int x = T.other(*it, v);
      if (!done[x]) relax(x, d + (pos(x) - pos(v)).norm());
    }
    if (!opt.fast_marching) continue;
    // Triangle updates: each face around v with one other accepted vertex updates the third.
    auto [fb, fe] = T.faces_of(v);
    for (const int* it = fb; it != fe; ++it) {
      const int f = *it;
      int j = 0;
      while (j < 3 && mesh.F(f, j) != v) ++j;
      if (j == 3) continue;
      const int a = mesh.F(f, (j + 1) % 3), b = mesh.F(f, (j + 2) % 3);
      if (done[a] && !done[b])
        relax(b, triangle_update(pos(v), pos(a), pos(b), d, D.distance[a]));
      else if (done[b] && !done[a])
        relax(a, triangle_update(pos(v), pos(b), pos(a), d, D.distance[b]));
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
