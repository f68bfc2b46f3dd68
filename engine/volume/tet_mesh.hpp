// A curved high-order tetrahedral mesh with its boundary triangles, nodes shared by index.
#pragma once
#include "engine/core/mesh.hpp"

#include <Eigen/Core>
#include <vector>

namespace hocurve {

/// Order-p tets and the order-p triangles of their boundary, sharing one node array.
/// - X: #N x 3 nodes; rows [0, num_vertices) are the linear tets' vertices (the surface's
///   vertices first, same indices as the input surface), then edge, face and interior nodes.
/// - T: #T x tet_node_count(p) node indices in Gmsh's tet order.
/// - B: #F x triangle_node_count(p) node indices in Gmsh's triangle order, row f = face f of
///   the input surface (same corners, same orientation).
/// - fixed: #N, 1 for the boundary's nodes (those of B), which nothing may move.
/// - face_entity / physicals: the surface's entities and groups, carried over.
struct TetMesh {
  int order = 1;
  int num_vertices = 0;
  Eigen::MatrixXd X;
  Eigen::MatrixXi T;
  Eigen::MatrixXi B;
  std::vector<char> fixed;
  Eigen::VectorXi face_entity;
  std::vector<PhysicalGroup> physicals;

  int num_tets() const { return static_cast<int>(T.rows()); }
  /// Nodes of tet t, #nodes x 3 in Gmsh order.
  Eigen::MatrixXd tet_nodes(int t) const {
    Eigen::MatrixXd P(T.cols(), 3);
    for (Eigen::Index k = 0; k < T.cols(); ++k) P.row(k) = X.row(T(t, k));
    return P;
  }
};

/// The tets around each node (CSR): tets[start[i] .. start[i + 1]) hold node i.
struct NodeTets {
  std::vector<int> start, tets;
  explicit NodeTets(const TetMesh& tm) : start(tm.X.rows() + 1, 0), tets(tm.T.size()) {
    for (Eigen::Index i = 0; i < tm.T.size(); ++i) ++start[tm.T.data()[i] + 1];
    for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int t = 0; t < tm.num_tets(); ++t)
      for (Eigen::Index k = 0; k < tm.T.cols(); ++k) tets[fill[tm.T(t, k)]++] = t;
  }
};

}  // namespace hocurve
