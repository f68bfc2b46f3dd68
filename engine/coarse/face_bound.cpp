#include "engine/coarse/face_bound.hpp"

#include "engine/core/union_find.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace hocurve {

int fewest_faces_keeping(const Mesh& m, const Topology& T, const std::vector<char>& edge_feature,
                         const std::vector<char>& corner) {
  const int nv = m.num_vertices(), ne = T.num_edges(), nf = m.num_faces();
  std::vector<int> parent(nv);
  for (int v = 0; v < nv; ++v) parent[v] = v;
  for (int f = 0; f < nf; ++f)
    for (int j = 1; j < 3; ++j) parent[find_root(parent, m.F(f, j))] = find_root(parent, m.F(f, 0));
  // Per component (by root): vertices the coarse mesh must have, weighted 1 on the boundary and
  // 2 elsewhere (F = 2 V - B - 2 chi), Euler characteristic, open or closed.
  std::vector<long long> weight(nv, 0), chi(nv, 0);
  std::vector<char> open(nv, 0), boundary_vertex(nv, 0), used(nv, 0);
  for (int e = 0; e < ne; ++e) {
    chi[find_root(parent, T.E(e, 0))] -= 1;
    if (T.edge_faces[e].size() == 1) boundary_vertex[T.E(e, 0)] = boundary_vertex[T.E(e, 1)] = 1;
  }
  for (int f = 0; f < nf; ++f) {
    chi[find_root(parent, m.F(f, 0))] += 1;
    for (int j = 0; j < 3; ++j) used[m.F(f, j)] = 1;
  }
  for (int v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    const int c = find_root(parent, v);
    chi[c] += 1;
    if (boundary_vertex[v]) open[c] = 1;
    if (corner[v]) weight[c] += boundary_vertex[v] ? 1 : 2;
  }
  // Walk the curves: from each corner along each of its feature edges to the next corner.
  std::vector<char> walked(ne, 0);
  auto walk = [&](int v, int e) {  // the far end; marks the edges
    int cur = T.other(e, v);
    walked[e] = 1;
    while (!corner[cur]) {
      int next = -1;
      auto [b, end] = T.edges_of(cur);
      for (const int* it = b; it != end; ++it)
        if (edge_feature[*it] && !walked[*it]) next = *it;
      if (next < 0) break;  // back at the start of a closed loop
      walked[next] = 1;
      cur = T.other(next, cur);
    }
    return cur;
  };
  std::map<std::pair<int, int>, int> between;  // curves per corner pair
  for (int v = 0; v < nv; ++v) {
    if (!corner[v]) continue;
    auto [b, end] = T.edges_of(v);
    for (const int* it = b; it != end; ++it) {
      if (!edge_feature[*it] || walked[*it]) continue;
      const int w = walk(v, *it);
      const int per_vertex = T.edge_faces[*it].size() == 1 ? 1 : 2;
      if (w == v) weight[find_root(parent, v)] += 2 * per_vertex;  // two more vertices close the loop
      else if (between[std::minmax(v, w)]++ > 0) weight[find_root(parent, v)] += per_vertex;  // a second curve: one
    }
  }
  for (int e = 0; e < ne; ++e)  // closed loops without corners: three vertices each
    if (edge_feature[e] && !walked[e]) {
      walk(T.E(e, 0), e);
      weight[find_root(parent, T.E(e, 0))] += 3 * (T.edge_faces[e].size() == 1 ? 1 : 2);
    }
  long long faces = 0;
  for (int v = 0; v < nv; ++v) {
    if (!used[v] || find_root(parent, v) != v) continue;
    // A closed surface of Euler characteristic chi needs ceil((7 + sqrt(49 - 24 chi)) / 2)
    // vertices (Heawood): 4 for a sphere, 7 for a torus. An open one, one triangle.
    long long least = 1;
    if (!open[v]) {
      const long long heawood = static_cast<long long>(std::ceil((7 + std::sqrt(49.0 - 24.0 * chi[v])) / 2 - 1e-9));
      least = 2 * heawood - 2 * chi[v];
    }
    faces += std::max(weight[v] - 2 * chi[v], least);
  }
  return static_cast<int>(faces);
}

}  // namespace hocurve
