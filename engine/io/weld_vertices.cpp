#include "engine/io/weld_vertices.hpp"

#include "engine/core/union_find.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

namespace hocurve {
namespace {

template <class Real> struct Bits;
template <> struct Bits<float> { using type = std::uint32_t; };
template <> struct Bits<double> { using type = std::uint64_t; };

inline std::uint64_t mix(std::uint64_t h) {  // splitmix64 finaliser: cheap, well spread
  h ^= h >> 30; h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27; h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

template <class Real>
WeldResult<Real> weld_impl(const Real* xyz, std::size_t n) {
  using U = typename Bits<Real>::type;
  WeldResult<Real> r;
  r.index.resize(n);
  std::vector<U> keys;  // unique points' bit patterns, 3 per point
  // Closed meshes have about n/6 unique points; start there and grow at 50% load.
  std::size_t cap = 1024;
  while (cap < n / 3) cap <<= 1;
  std::vector<int> table(cap, -1);
  auto slot_of = [&](const U* k, std::size_t mask) {
    std::uint64_t h = mix(std::uint64_t(k[0]) * 0x9E3779B97F4A7C15ULL ^ mix(std::uint64_t(k[1]) + 0x632BE59BD9B4E019ULL) ^
                          (std::uint64_t(k[2]) << 1));
    return static_cast<std::size_t>(h) & mask;
  };
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    U k[3];
    for (int d = 0; d < 3; ++d) {
      Real x = xyz[3 * i + d];
      if (x == Real(0)) x = Real(0);  // -0 and +0 are the same position
      std::memcpy(&k[d], &x, sizeof(U));
    }
    if (2 * (count + 1) > cap) {  // grow and re-insert
      cap <<= 1;
      table.assign(cap, -1);
      for (std::size_t u = 0; u < count; ++u) {
        std::size_t s = slot_of(&keys[3 * u], cap - 1);
        while (table[s] >= 0) s = (s + 1) & (cap - 1);
        table[s] = static_cast<int>(u);
      }
    }
    const std::size_t mask = cap - 1;
    std::size_t s = slot_of(k, mask);
    for (;;) {
      const int u = table[s];
      if (u < 0) {
        table[s] = static_cast<int>(count);
        keys.insert(keys.end(), k, k + 3);
        r.index[i] = static_cast<int>(count++);
        break;
      }
      const U* q = &keys[3 * static_cast<std::size_t>(u)];
      if (q[0] == k[0] && q[1] == k[1] && q[2] == k[2]) {
        r.index[i] = u;
        break;
      }
      s = (s + 1) & mask;
    }
  }
  r.points.resize(keys.size());
  if (!keys.empty())  // memcpy from an empty vector's null data() is undefined
    std::memcpy(r.points.data(), keys.data(), keys.size() * sizeof(U));
  return r;
}

}  // namespace

WeldResult<float> weld_exact(const float* xyz, std::size_t n) { return weld_impl(xyz, n); }
WeldResult<double> weld_exact(const double* xyz, std::size_t n) { return weld_impl(xyz, n); }

}  // namespace hocurve

namespace hocurve {

std::vector<int> weld_within(const Eigen::MatrixXd& V, double tol) {
  const Eigen::Index n = V.rows();
  std::vector<int> parent(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  if (n == 0 || !(tol > 0)) return parent;
  // Sweep along a fixed direction no CAD plane is perpendicular to: points within tol of each
  // other are within tol along it, and few others are (a hash grid cost 4x the read on 1.2M points).
  const Eigen::Vector3d dir = Eigen::Vector3d(0.5406, 0.6182, 0.5708).normalized();
  std::vector<std::pair<double, int>> order(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = {V.row(i).dot(dir), static_cast<int>(i)};
  std::sort(order.begin(), order.end());
  for (std::size_t a = 0; a < order.size(); ++a)
    for (std::size_t b = a + 1; b < order.size() && order[b].first - order[a].first <= tol; ++b) {
      const int i = order[a].second, j = order[b].second;
      if ((V.row(i) - V.row(j)).norm() > tol) continue;
      const int ri = find_root(parent, i), rj = find_root(parent, j);
      if (ri != rj) parent[std::max(ri, rj)] = std::min(ri, rj);
    }
  for (Eigen::Index i = 0; i < n; ++i) parent[static_cast<std::size_t>(i)] = find_root(parent, static_cast<int>(i));
  return parent;
}

}  // namespace hocurve
