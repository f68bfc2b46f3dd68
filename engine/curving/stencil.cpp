#include "engine/curving/stencil.hpp"

#include "engine/core/union_find.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>

namespace hocurve {

Wedges build_wedges(const Mesh& mesh, const Topology& T, const std::vector<char>& edge_feature,
                    const std::vector<char>& cone_vertex) {
  const int nv = mesh.num_vertices();
  const int nf = mesh.num_faces();
  Wedges W;
  if (std::find(cone_vertex.begin(), cone_vertex.end(), 1) != cone_vertex.end()) W.cone = cone_vertex;
  W.corner_wedge = Eigen::MatrixXi::Constant(nf, 3, -1);
  W.vertex_wedge_start.assign(nv + 1, 0);
  W.wedge_start.push_back(0);
  W.wedge_vertex.reserve(nv);
  W.wedge_start.reserve(static_cast<size_t>(nv) + 1);
  W.wedge_faces.reserve(3 * static_cast<size_t>(nf));
  auto is_feature = [&](int e) {
    return (!edge_feature.empty() && edge_feature[e]) || T.edge_faces[e].size() != 2;
  };
  // Per-vertex buffers, reused: this runs once per vertex.
  std::vector<int> faces, parent, group_id, group_size, group_pos, order;
  for (int v = 0; v < nv; ++v) {
    auto [fb, fe] = T.faces_of(v);
    faces.assign(fb, fe);
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    const int k = static_cast<int>(faces.size());
    parent.resize(k);
    std::iota(parent.begin(), parent.end(), 0);
    auto local = [&](int f) {
      return static_cast<int>(std::lower_bound(faces.begin(), faces.end(), f) - faces.begin());
    };
    // Join faces that share a non-feature manifold edge incident to v.
    for (int a = 0; a < k; ++a) {
      const int f = faces[a];
      for (int j = 0; j < 3; ++j) {
        if (mesh.F(f, j) != v) continue;
        for (int e : {T.FE(f, j), T.FE(f, (j + 2) % 3)}) {
          if (is_feature(e)) continue;
          for (int g : T.edge_faces[e])
            if (g != f) {
              int ra = find_root(parent, a), rb = find_root(parent, local(g));
              if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
            }
        }
      }
    }
    // Number the groups by their smallest face (faces are sorted: first appearance order),
    // then write each group's faces in ascending order (a counting sort by group).
    group_id.assign(k, -1);
    group_size.clear();
    order.resize(k);
    for (int a = 0; a < k; ++a) {
      const int r = find_root(parent, a);
      if (group_id[r] < 0) group_id[r] = static_cast<int>(group_size.size()), group_size.push_back(0);
      order[a] = group_id[r];
      ++group_size[group_id[r]];
    }
    const int ng = static_cast<int>(group_size.size());
    const int w0 = W.num_wedges();
    const size_t base = W.wedge_faces.size();
    W.wedge_faces.resize(base + k);
    group_pos.resize(ng);
    for (int g = 0, pos = 0; g < ng; ++g) {
      group_pos[g] = pos;
      pos += group_size[g];
      W.wedge_vertex.push_back(v);
      W.wedge_start.push_back(static_cast<int>(base) + pos);
    }
    for (int a = 0; a < k; ++a) {
      const int f = faces[a];
      const int g = order[a];
      W.wedge_faces[base + group_pos[g]++] = f;
      for (int j = 0; j < 3; ++j)
        if (mesh.F(f, j) == v) W.corner_wedge(f, j) = w0 + g;
    }
    W.vertex_wedge_start[v + 1] = W.num_wedges();
  }
  return W;
}

Stencil grow_stencil(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                     const StencilOptions& opt) {
  StencilScratch scratch;
  return grow_stencil(mesh, T, W, w, opt, scratch);
}

Stencil grow_stencil(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                     const StencilOptions& opt, StencilScratch& scratch) {
  (void)T;
  StampSet& region = scratch.faces;
  StampSet& verts = scratch.vertices;
  std::vector<int>& frontier = scratch.frontier;
  std::vector<int>& new_faces = scratch.new_faces;
  region.clear();
  verts.clear();
  Stencil S;
  const int centre = W.wedge_vertex[w];
  new_faces.assign(W.wedge_faces.begin() + W.wedge_start[w], W.wedge_faces.begin() + W.wedge_start[w + 1]);
  S.vertices.push_back(centre);
  verts.insert(centre);
  for (int f : new_faces)
    if (region.insert(f)) S.faces.push_back(f);
  auto add_vertices_of = [&](const std::vector<int>& faces) {
    frontier.clear();
    for (int f : faces)
      for (int j = 0; j < 3; ++j) {
        int u = mesh.F(f, j);
        if (verts.insert(u)) frontier.push_back(u);
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
      if (W.is_cone(u)) continue;  // a wall, as a feature curve is
      for (int uw = W.vertex_wedge_start[u]; uw < W.vertex_wedge_start[u + 1]; ++uw) {
        const int* b = W.wedge_faces.data() + W.wedge_start[uw];
        const int* e = W.wedge_faces.data() + W.wedge_start[uw + 1];
        // u came from a region face, so u's only wedge (the usual case) is touched.
        const bool only = W.vertex_wedges(u) == 1;
        if (!only && !std::any_of(b, e, [&](int f) { return region.contains(f); })) continue;
        for (const int* p = b; p != e; ++p)
          if (region.insert(*p)) new_faces.push_back(*p);
      }
    }
    if (new_faces.empty()) break;
    S.faces.insert(S.faces.end(), new_faces.begin(), new_faces.end());
    std::sort(new_faces.begin(), new_faces.end());
    add_vertices_of(new_faces);
    ++S.rings;
  }
  std::sort(S.faces.begin(), S.faces.end());
  return S;
}

EdgeFrame edge_frame(const Mesh& mesh, const Topology& T, int e, Eigen::Vector3d normal) {
  EdgeFrame F;
  const Eigen::Vector3d pa = mesh.V.row(T.E(e, 0)), pb = mesh.V.row(T.E(e, 1));
  F.h = (pb - pa).norm();
  if (!(F.h > 0) || !(normal.norm() > 1e-12)) return F;
  F.n = normal.normalized();
  F.t = ((pb - pa) - (pb - pa).dot(F.n) * F.n).normalized();
  F.s = F.n.cross(F.t);
  F.o = 0.5 * (pa + pb);
  F.valid = F.t.allFinite();
  return F;
}

EdgeFrame edge_frame(const Mesh& mesh, const Topology& T, int e) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  for (int f : T.edge_faces[e]) {
    const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)), p2 = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d m = (p1 - p0).cross(p2 - p0);
    if (m.norm() > 0) n += m.normalized();
  }
  return edge_frame(mesh, T, e, n);
}

void edge_region_vertices(const Mesh& mesh, const Topology& T, const std::vector<char>& wall, int e, int rings,
                          std::vector<int>& faces, StampSet& seen, std::vector<int>& out) {
  faces.assign(T.edge_faces[e].begin(), T.edge_faces[e].end());
  seen.clear();
  for (int f : faces) seen.insert(f);
  for (int step = 0, begin = 0; step < rings; ++step) {
    const int end = static_cast<int>(faces.size());
    for (int i = begin; i < end; ++i)
      for (int j = 0; j < 3; ++j) {
        const int g = T.FE(faces[i], j);
        if (wall[g] || T.edge_faces[g].size() != 2) continue;
        for (int f : T.edge_faces[g])
          if (seen.insert(f)) faces.push_back(f);
      }
    begin = end;
  }
  out.clear();
  seen.clear();
  for (int f : faces)
    for (int j = 0; j < 3; ++j)
      if (seen.insert(mesh.F(f, j))) out.push_back(mesh.F(f, j));
  std::sort(out.begin(), out.end());
}

}  // namespace hocurve
