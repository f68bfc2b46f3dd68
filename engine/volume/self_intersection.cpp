// Sweep and prune on x, then segment-triangle crossings by the signs of tet volumes.
#include "engine/volume/self_intersection.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>
#include <vector>

namespace hocurve {

namespace {

using V3 = Eigen::Vector3d;

double orient(const V3& a, const V3& b, const V3& c, const V3& d) { return (b - a).dot((c - a).cross(d - a)); }

// Does segment pq cross triangle abc (strictly: its ends on opposite sides, the line through
// the inside of the triangle)?
bool crosses(const V3& p, const V3& q, const V3& a, const V3& b, const V3& c) {
  const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if (!(sp * sq < 0)) return false;
  const double s1 = orient(p, q, a, b), s2 = orient(p, q, b, c), s3 = orient(p, q, c, a);
  return (s1 > 0 && s2 > 0 && s3 > 0) || (s1 < 0 && s2 < 0 && s3 < 0);
}

bool faces_cross(const Mesh& m, int f, int g) {
  V3 a[3], b[3];
  for (int k = 0; k < 3; ++k) a[k] = m.V.row(m.F(f, k)), b[k] = m.V.row(m.F(g, k));
  for (int k = 0; k < 3; ++k)
    if (crosses(a[k], a[(k + 1) % 3], b[0], b[1], b[2]) || crosses(b[k], b[(k + 1) % 3], a[0], a[1], a[2]))
      return true;
  return false;
}

}  // namespace

std::optional<std::pair<int, int>> find_self_intersection(const Mesh& m) {
  const int n = m.num_faces();
  Eigen::MatrixXd lo(n, 3), hi(n, 3);
  for (int f = 0; f < n; ++f) {
    lo.row(f) = m.V.row(m.F(f, 0)).cwiseMin(m.V.row(m.F(f, 1))).cwiseMin(m.V.row(m.F(f, 2)));
    hi.row(f) = m.V.row(m.F(f, 0)).cwiseMax(m.V.row(m.F(f, 1))).cwiseMax(m.V.row(m.F(f, 2)));
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return lo(a, 0) < lo(b, 0); });
  std::optional<std::pair<int, int>> best;
  for (int i = 0; i < n; ++i) {
    const int f = order[i];
    for (int j = i + 1; j < n && lo(order[j], 0) <= hi(f, 0); ++j) {
      const int g = order[j];
      if ((lo.row(g).array() > hi.row(f).array()).any() || (lo.row(f).array() > hi.row(g).array()).any()) continue;
      bool shared = false;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) shared |= m.F(f, a) == m.F(g, b);
      if (shared || !faces_cross(m, f, g)) continue;
      const std::pair<int, int> p = std::minmax(f, g);
      if (!best || p < *best) best = p;
    }
  }
  return best;
}

}  // namespace hocurve
