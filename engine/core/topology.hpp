// Edge and vertex adjacency of a triangle mesh, built once and shared by every stage.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace hocurve {

/// Unique undirected edges and their incidences.
/// - E: #E x 2, E(e,0) < E(e,1).
/// - FE: #F x 3, FE(f,j) = edge j of face f joins corner j to corner (j+1)%3.
/// - edge_faces[e]: the faces that use edge e (1 = boundary, 2 = manifold, >2 = non-manifold).
/// - vertex_faces[v]: faces incident to vertex v (CSR: vf_start has #V+1 entries).
struct Topology {
  Eigen::MatrixXi E;
  Eigen::MatrixXi FE;
  std::vector<std::vector<int>> edge_faces;
  std::vector<int> vf_start, vf_faces;
  std::vector<int> ve_start, ve_edges;  ///< vertex -> incident edges (CSR)

  int num_edges() const { return static_cast<int>(E.rows()); }
  /// Faces around vertex v.
  std::pair<const int*, const int*> faces_of(int v) const {
    return {vf_faces.data() + vf_start[v], vf_faces.data() + vf_start[v + 1]};
  }
  /// Edges around vertex v.
  std::pair<const int*, const int*> edges_of(int v) const {
    return {ve_edges.data() + ve_start[v], ve_edges.data() + ve_start[v + 1]};
  }
  /// The vertex of edge e that is not v.
  int other(int e, int v) const { return E(e, 0) == v ? E(e, 1) : E(e, 0); }
};

/// Builds edges, face-edge and vertex incidences of F for a mesh with num_vertices vertices.
Topology build_topology(const Eigen::MatrixXi& F, int num_vertices);

}  // namespace hocurve
