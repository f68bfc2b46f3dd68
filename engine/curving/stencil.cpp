#include "engine/curving/stencil.hpp"

#include <algorithm>
#include <numeric>
#include <unordered_set>

namespace hocurve {

namespace {
int find_root(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}
}  // namespace

Wedges build_wedges(const Mesh& mesh, const Topology& T, const std::vector<char>& edge_feature) {
  const int nv = mesh.num_vertices();
  const int nf = mesh.num_faces();
  Wedges W;
  W.corner_wedge = Eigen::MatrixXi::Constant(nf, 3, -1);
  W.vertex_wedge_start.assign(nv + 1, 0);
  W.wedge_start.push_back(0);
  auto is_feature = [&](int e) {
    return (!edge_feature.empty() && edge_feature[e]) || T.edge_faces[e].size() != 2;
  };
  std::vector<int> parent;
  for (int v = 0; v < nv; ++v) {
    auto [fb, fe] = T.faces_of(v);
    const int k = static_cast<int>(fe - fb);
    std::vector<int> faces(fb, fe);
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    parent.resize(faces.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto local = [&](int f) {
      return static_cast<int>(std::lower_bound(faces.begin(), faces.end(), f) - faces.begin());
    };
    // Join faces that share a non-feature manifold edge incident to v.
    for (size_t a = 0; a < faces.size(); ++a) {
      const int f = faces[a];
      for (int j = 0; j < 3; ++j) {
        if (mesh.F(f, j) != v) continue;
        for (int e : {T.FE(f, j), T.FE(f, (j + 2) % 3)}) {
          if (is_feature(e)) continue;
          for (int g : T.edge_faces[e])
            if (g != f) {
              int ra = find_root(parent, static_cast<int>(a)), rb = find_root(parent, local(g));
              if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
            }
        }
      }
    }
    // Number the groups by their smallest face (faces are sorted: first appearance order).
    std::vector<int> group_id(faces.size(), -1);
    std::vector<std::vector<int>> groups;
    for (size_t a = 0; a < faces.size(); ++a) {
      int r = find_root(parent, static_cast<int>(a));
      if (group_id[r] < 0) group_id[r] = static_cast<int>(groups.size()), groups.emplace_back();
      groups[group_id[r]].push_back(faces[a]);
    }
    for (auto& g : groups) {
      const int w = W.num_wedges();
      W.wedge_vertex.push_back(v);
      for (int f : g) {
        W.wedge_faces.push_back(f);
        for (int j = 0; j < 3; ++j)
          if (mesh.F(f, j) == v) W.corner_wedge(f, j) = w;
      }
      W.wedge_start.push_back(static_cast<int>(W.wedge_faces.size()));
    }
    W.vertex_wedge_start[v + 1] = W.num_wedges();
    (void)k;
  }
  return W;
}

Stencil grow_stencil(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                     const StencilOptions& opt) {
  Stencil S;
  const int centre = W.wedge_vertex[w];
  std::unordered_set<int> region, verts;
  std::vector<int> new_faces(W.wedge_faces.begin() + W.wedge_start[w],
                             W.wedge_faces.begin() + W.wedge_start[w + 1]);
  S.vertices.push_back(centre);
  verts.insert(centre);
  for (int f : new_faces) region.insert(f);
  std::vector<int> frontier;
  auto add_vertices_of = [&](const std::vector<int>& faces) {
    frontier.clear();
    for (int f : faces)
      for (int j = 0; j < 3; ++j) {
        int u = mesh.F(f, j);
        if (verts.insert(u).second) frontier.push_back(u);
      }
    std::sort(frontier.begin(), frontier.end());
    S.vertices.insert(S.vertices.end(), frontier.begin(), frontier.end());
  };
  add_vertices_of(new_faces);
  S.rings = 1;
  while (!frontier.empty() && S.rings < opt.max_rings &&
         (S.rings < opt.min_rings ||
          (static_cast<int>(S.vertices.size()) < opt.target_points &&
           static_cast<int>(S.vertices.size()) < opt.max_points))) {
    new_faces.clear();
    for (int u : frontier) {
      for (int uw = W.vertex_wedge_start[u]; uw < W.vertex_wedge_start[u + 1]; ++uw) {
        const int* b = W.wedge_faces.data() + W.wedge_start[uw];
        const int* e = W.wedge_faces.data() + W.wedge_start[uw + 1];
        bool touched = std::any_of(b, e, [&](int f) { return region.count(f) > 0; });
        if (!touched) continue;
        for (const int* p = b; p != e; ++p)
          if (region.insert(*p).second) new_faces.push_back(*p);
      }
    }
    if (new_faces.empty()) break;
    std::sort(new_faces.begin(), new_faces.end());
    add_vertices_of(new_faces);
    ++S.rings;
  }
  S.faces.assign(region.begin(), region.end());
  std::sort(S.faces.begin(), S.faces.end());
  (void)T;
  return S;
}

}  // namespace hocurve
