// Caps found by their boundary faces; edges split one at a time with a vertex -> tets map
// kept up to date.
#include "engine/volume/split_caps.hpp"

#include <algorithm>
#include <array>
#include <set>

namespace hocurve {

namespace {

std::array<int, 3> sorted(int a, int b, int c) {
  std::array<int, 3> f{a, b, c};
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace

long long split_cap_tets(LinearTets& lin, const Mesh& s) {
  std::set<std::array<int, 3>> faces;
  std::set<std::pair<int, int>> edges;
  for (int f = 0; f < s.num_faces(); ++f) {
    faces.insert(sorted(s.F(f, 0), s.F(f, 1), s.F(f, 2)));
    for (int j = 0; j < 3; ++j)
      edges.insert(std::minmax(s.F(f, j), s.F(f, (j + 1) % 3)));
  }
  // Inside edges of caps.
  std::set<std::pair<int, int>> split;
  for (Eigen::Index t = 0; t < lin.T.rows(); ++t) {
    int on = 0, off_corner = 0;  // off_corner: bitmask of the corners opposite the boundary faces
    for (int k = 0; k < 4; ++k) {
      const int a = lin.T(t, (k + 1) % 4), b = lin.T(t, (k + 2) % 4), c = lin.T(t, (k + 3) % 4);
      if (faces.count(sorted(a, b, c))) ++on, off_corner |= 1 << k;
    }
    if (on != 2) continue;
    int c[2], m = 0;
    for (int k = 0; k < 4; ++k)
      if (off_corner >> k & 1) c[m++] = lin.T(t, k);
    const auto e = std::minmax(c[0], c[1]);
    if (!edges.count(e)) split.insert(e);
  }
  if (split.empty()) return 0;

  std::vector<std::array<int, 4>> T(lin.T.rows());
  for (Eigen::Index t = 0; t < lin.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) T[t][k] = lin.T(t, k);
  std::vector<Eigen::RowVector3d> V(lin.V.rows());
  for (Eigen::Index v = 0; v < lin.V.rows(); ++v) V[v] = lin.V.row(v);
  std::vector<std::vector<int>> vt(V.size());
  for (int t = 0; t < static_cast<int>(T.size()); ++t)
    for (int k = 0; k < 4; ++k) vt[T[t][k]].push_back(t);
  for (const auto& [c, d] : split) {
    const int m = static_cast<int>(V.size());
    V.push_back(0.5 * (V[c] + V[d]));
    vt.emplace_back();
    std::vector<int> around;
    for (int t : vt[c])
      if (std::find(T[t].begin(), T[t].end(), d) != T[t].end()) around.push_back(t);
    for (int t : around) {
      // t keeps c (d -> m); the new tet keeps d (c -> m). Same orientation: m is on c-d.
      std::array<int, 4> u = T[t];
      std::replace(T[t].begin(), T[t].end(), d, m);
      std::replace(u.begin(), u.end(), c, m);
      const int nt = static_cast<int>(T.size());
      T.push_back(u);
      std::erase(vt[d], t);
      for (int v : u) vt[v].push_back(nt);
      vt[m].push_back(t);
    }
  }
  lin.T.resize(static_cast<Eigen::Index>(T.size()), 4);
  for (std::size_t t = 0; t < T.size(); ++t)
    for (int k = 0; k < 4; ++k) lin.T(static_cast<Eigen::Index>(t), k) = T[t][k];
  lin.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (std::size_t v = 0; v < V.size(); ++v) lin.V.row(static_cast<Eigen::Index>(v)) = V[v];
  return static_cast<long long>(split.size());
}

}  // namespace hocurve
