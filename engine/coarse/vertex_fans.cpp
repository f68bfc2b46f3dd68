#include "engine/coarse/vertex_fans.hpp"

#include "engine/core/topology.hpp"

#include <algorithm>

namespace hocurve {

int vertex_fans(const Mesh& m, const Topology& T, int v, std::vector<int>& fan) {
  auto [b, e] = T.faces_of(v);
  const int k = static_cast<int>(e - b);
  // Vertices x whose edge (v, x) has exactly two faces: only those edges link fans.
  std::vector<int> linking;
  for (auto [eb, ee] = T.edges_of(v); eb != ee; ++eb)
    if (T.edge_faces[*eb].size() == 2) linking.push_back(T.other(*eb, v));
  auto links = [&](int x) { return std::find(linking.begin(), linking.end(), x) != linking.end(); };
  fan.assign(k, -1);
  int fans = 0;
  std::vector<int> stack;
  for (int start = 0; start < k; ++start) {
    if (fan[start] >= 0) continue;
    stack.assign(1, start);
    fan[start] = fans;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      for (int j = 0; j < k; ++j) {
        if (fan[j] >= 0) continue;
        bool shared = false;  // faces i and j around v share an edge (v, x) of two faces
        for (int a = 0; a < 3; ++a) {
          const int x = m.F(b[i], a);
          if (x == v || !links(x)) continue;
          for (int c = 0; c < 3; ++c) shared = shared || m.F(b[j], c) == x;
        }
        if (shared) fan[j] = fans, stack.push_back(j);
      }
    }
    ++fans;
  }
  return fans;
}

FanSplit split_vertex_fans(const Mesh& m) {
  FanSplit R;
  R.mesh = m;
  const int nv = m.num_vertices();
  R.original.resize(nv);
  for (int v = 0; v < nv; ++v) R.original[v] = v;
  const Topology T = build_topology(m.F, nv);
  for (int e = 0; e < T.num_edges(); ++e) R.nonmanifold_edges += T.edge_faces[e].size() > 2;
  std::vector<int> fan;
  for (int v = 0; v < nv; ++v) {
    const int fans = vertex_fans(m, T, v, fan);
    if (fans <= 1) continue;
    ++R.split_vertices;
    R.pinned.push_back(v);
    const int first = R.mesh.num_vertices();
    R.mesh.V.conservativeResize(first + fans - 1, 3);
    for (int c = 1; c < fans; ++c) {
      R.mesh.V.row(first + c - 1) = m.V.row(v);
      R.pinned.push_back(first + c - 1);
      R.original.push_back(v);
    }
    auto [b, e] = T.faces_of(v);
    for (int i = 0; i < static_cast<int>(e - b); ++i)
      if (fan[i] > 0)
        for (int x = 0; x < 3; ++x)
          if (R.mesh.F(b[i], x) == v) R.mesh.F(b[i], x) = first + fan[i] - 1;
  }
  return R;
}

std::vector<int> coarse_vertex_copies(const FanSplit& split, const std::vector<int>& origin) {
  std::vector<int> first(split.original.size(), -1), same(origin.size());
  for (std::size_t c = 0; c < origin.size(); ++c) {
    if (origin[c] < 0) { same[c] = static_cast<int>(c); continue; }  // made by a split: no copies
    int& f = first[split.original[origin[c]]];
    if (f < 0) f = static_cast<int>(c);
    same[c] = f;
  }
  return same;
}

HighOrderMesh rejoin_vertex_copies(const HighOrderMesh& hm, const std::vector<int>& same) {
  const int nv = static_cast<int>(hm.V.rows()), nf = hm.num_faces(), npe = hm.nodes_per_edge();
  std::vector<int> index(nv, -1);
  int kept = 0;
  for (int v = 0; v < nv; ++v)
    if (same[v] == v) index[v] = kept++;
  for (int v = 0; v < nv; ++v) index[v] = index[same[v]];
  Mesh joined;
  joined.V.resize(kept, 3);
  for (int v = 0; v < nv; ++v)
    if (same[v] == v) joined.V.row(index[v]) = hm.V.row(v);
  joined.F.resize(nf, 3);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) joined.F(f, j) = index[hm.F(f, j)];
  joined.face_entity = hm.face_entity;
  joined.physicals = hm.physicals;
  const Topology T = build_topology(joined.F, kept);
  HighOrderMesh out = high_order_frame(joined, T, hm.order, hm.distribution);
  out.face_nodes = hm.face_nodes;
  // Edge nodes: a copy that is an inner edge (two faces) of its part was fitted across it and
  // wins (the sheet a fin stands on keeps its surface); else the mean of the copies, which are all
  // open boundaries fitted to the same dense curve.
  std::vector<int> old_faces(hm.E.rows(), 0);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) ++old_faces[hm.FE(f, j)];
  out.edge_nodes.setZero();
  std::vector<int> count(T.num_edges(), 0);
  std::vector<char> done(hm.E.rows(), 0), inner(T.num_edges(), 0);
  auto nodes_of = [&](int e, int g) {
    const bool reversed = index[hm.E(e, 0)] != out.E(g, 0);
    Eigen::MatrixXd X(npe, 3);
    for (int k = 0; k < npe; ++k) X.row(k) = hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + (reversed ? npe - 1 - k : k));
    return X;
  };
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      const int e = hm.FE(f, j), g = out.FE(f, j);
      if (done[e] || inner[g]) continue;
      done[e] = 1;
      auto rows = out.edge_nodes.middleRows(static_cast<Eigen::Index>(g) * npe, npe);
      if (old_faces[e] == 2) {
        rows = nodes_of(e, g), count[g] = 1, inner[g] = 1;
      } else {
        rows += nodes_of(e, g), ++count[g];
      }
    }
  for (int g = 0; g < T.num_edges(); ++g)
    if (count[g] > 1) out.edge_nodes.middleRows(static_cast<Eigen::Index>(g) * npe, npe) /= count[g];
  return out;
}

}  // namespace hocurve
