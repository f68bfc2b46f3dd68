#include "engine/coarse/vertex_fans.hpp"

#include "engine/core/topology.hpp"

namespace hocurve {

int vertex_fans(const Mesh& m, const Topology& T, int v, std::vector<int>& fan) {
  auto [b, e] = T.faces_of(v);
  const int k = static_cast<int>(e - b);
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
        int shared = 0;  // two faces around v sharing one more vertex share an edge at v
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y) shared += m.F(b[i], x) == m.F(b[j], y);
        if (shared >= 2) fan[j] = fans, stack.push_back(j);
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
  const Topology T = build_topology(m.F, nv);
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
    }
    auto [b, e] = T.faces_of(v);
    for (int i = 0; i < static_cast<int>(e - b); ++i)
      if (fan[i] > 0)
        for (int x = 0; x < 3; ++x)
          if (R.mesh.F(b[i], x) == v) R.mesh.F(b[i], x) = first + fan[i] - 1;
  }
  return R;
}

}  // namespace hocurve
