// A node is named by its lattice weights on the corners that carry it: edge nodes by two
// (corner, weight) pairs, face nodes by three. The same name from any tet or triangle is the
// same node.
#include "engine/volume/elevate.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <algorithm>
#include <unordered_map>

namespace hocurve {

namespace {

struct Key {
  std::uint64_t a = 0, b = 0;
  bool operator==(const Key&) const = default;
};
struct KeyHash {
  std::size_t operator()(const Key& k) const { return std::hash<std::uint64_t>()(k.a * 0x9E3779B97F4A7C15ull ^ k.b); }
};

// Key of the node with weights w[i] on corners c[i] (i < n, n <= 3 nonzero weights).
Key make_key(const int* c, const int* w, int n) {
  std::pair<int, int> cw[4];
  int m = 0;
  for (int i = 0; i < n; ++i)
    if (w[i]) cw[m++] = {c[i], w[i]};
  for (int i = 1; i < m; ++i)  // insertion sort (m <= 3; std::sort here trips -Warray-bounds)
    for (int j = i; j > 0 && cw[j] < cw[j - 1]; --j) std::swap(cw[j], cw[j - 1]);
  std::uint64_t x[3] = {0, 0, 0};
  for (int i = 0; i < m; ++i) x[i] = (static_cast<std::uint64_t>(cw[i].first) << 4 | cw[i].second) + 1;
  return Key{x[0] << 32 | x[1], x[2]};
}

}  // namespace

TetMesh elevate_tets(const LinearTets& lin, const HighOrderMesh& hm) {
  const int p = hm.order;
  if (p < 1 || p > 6) throw UsageError("elevate_tets: order " + std::to_string(p) + " out of range 1..6");
  if (hm.distribution != NodeDistribution::Equispaced)
    throw UsageError("elevate_tets: tets need equispaced nodes (Gmsh's Lagrange tets)");
  const int nvs = static_cast<int>(hm.V.rows()), nv = static_cast<int>(lin.V.rows());
  if (nv < nvs || (nvs && lin.V.topRows(nvs) != hm.V))
    throw std::runtime_error("elevate_tets: the tets' first vertices are not the surface's");
  TetMesh tm;
  tm.order = p;
  tm.num_vertices = nv;
  tm.face_entity = hm.face_entity;
  tm.physicals = hm.physicals;
  std::vector<Eigen::RowVector3d> nodes;
  nodes.reserve(nv + static_cast<std::size_t>(lin.T.rows()) * (tet_node_count(p) - 4) / 2);
  for (int v = 0; v < nv; ++v) nodes.push_back(lin.V.row(v));

  // Boundary: the surface's nodes, appended, and named.
  const int ntri = triangle_node_count(p);
  const Eigen::MatrixXi tl = triangle_lattice(p);
  std::unordered_map<Key, int, KeyHash> named;
  named.reserve(static_cast<std::size_t>(lin.T.rows()) * 6);
  std::vector<int> of_surface(hm.V.rows() + hm.edge_nodes.rows() + hm.face_nodes.rows(), -1);
  for (int v = 0; v < nvs; ++v) of_surface[v] = v;
  tm.B.resize(hm.num_faces(), ntri);
  std::vector<int> idx(ntri);
  for (int f = 0; f < hm.num_faces(); ++f) {
    element_node_indices(hm, f, idx.data());
    const int c[3] = {hm.F(f, 0), hm.F(f, 1), hm.F(f, 2)};
    for (int k = 0; k < ntri; ++k) {
      int& g = of_surface[idx[k]];
      if (g < 0) {
        g = static_cast<int>(nodes.size());
        nodes.push_back(node_position(hm, idx[k]).transpose());
        const int w[3] = {p - tl(k, 0) - tl(k, 1), tl(k, 0), tl(k, 1)};
        named.try_emplace(make_key(c, w, 3), g);
      }
      tm.B(f, k) = g;
    }
  }

  // Tets: named nodes are looked up or created straight; interior nodes are the tet's own.
  const int ntet = tet_node_count(p);
  const Eigen::MatrixXi L = tet_lattice(p);
  tm.T.resize(lin.T.rows(), ntet);
  for (Eigen::Index t = 0; t < lin.T.rows(); ++t) {
    const int c[4] = {lin.T(t, 0), lin.T(t, 1), lin.T(t, 2), lin.T(t, 3)};
    for (int k = 0; k < ntet; ++k) {
      const int w[4] = {p - L(k, 0) - L(k, 1) - L(k, 2), L(k, 0), L(k, 1), L(k, 2)};
      const int nonzero = (w[0] > 0) + (w[1] > 0) + (w[2] > 0) + (w[3] > 0);
      int g = -1;
      if (nonzero == 1) {
        g = c[std::max_element(w, w + 4) - w];
      } else {
        Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
        for (int i = 0; i < 4; ++i) x += (double(w[i]) / p) * lin.V.row(c[i]);
        if (nonzero == 4) {
          g = static_cast<int>(nodes.size());
          nodes.push_back(x);
        } else {
          int cc[3], ww[3], m = 0;
          for (int i = 0; i < 4; ++i)
            if (w[i]) cc[m] = c[i], ww[m++] = w[i];
          auto [it, added] = named.try_emplace(make_key(cc, ww, m), static_cast<int>(nodes.size()));
          if (added) nodes.push_back(x);
          g = it->second;
        }
      }
      tm.T(t, k) = g;
    }
  }
  tm.X.resize(static_cast<Eigen::Index>(nodes.size()), 3);
  for (std::size_t i = 0; i < nodes.size(); ++i) tm.X.row(static_cast<Eigen::Index>(i)) = nodes[i];
  tm.fixed.assign(nodes.size(), 0);
  for (Eigen::Index i = 0; i < tm.B.size(); ++i) tm.fixed[tm.B.data()[i]] = 1;
  return tm;
}

}  // namespace hocurve
