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

}  // namespace hocurve
