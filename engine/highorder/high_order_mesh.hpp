// A high-order triangle surface mesh whose edge nodes are stored once per edge, so the
// two triangles of an edge share them: conforming by construction.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/Core>
#include <vector>

namespace hocurve {

/// Order-p curved triangle surface mesh.
/// - V: #V x 3 corner vertices (the input's vertices, same indices).
/// - E: #E x 2 unique edges, E(e,0) < E(e,1); FE: #F x 3 face edges (edge j joins corner j and
///   corner (j+1)%3), as in Topology.
/// - edge_nodes: #E*(p-1) x 3; rows e*(p-1) .. e*(p-1)+p-2 are edge e's interior nodes walked
///   from E(e,0) to E(e,1).
/// - face_nodes: #F*m x 3 with m = (p-1)(p-2)/2; rows f*m .. f*m+m-1 are face f's interior
///   nodes in Gmsh's recursive interior order.
/// - face_entity / physicals: carried over from the input Mesh.
struct HighOrderMesh {
  int order = 1;
  NodeDistribution distribution = NodeDistribution::Equispaced;
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  Eigen::MatrixXi E;
  Eigen::MatrixXi FE;
  Eigen::MatrixXd edge_nodes;
  Eigen::MatrixXd face_nodes;
  Eigen::VectorXi face_entity;
  std::vector<PhysicalGroup> physicals;

  int num_faces() const { return static_cast<int>(F.rows()); }
  int nodes_per_edge() const { return order - 1; }
  int nodes_per_face() const { return (order - 1) * (order - 2) / 2; }
  int entity_of(int f) const { return face_entity.size() ? face_entity[f] : 1; }
};

/// Order-p mesh carrying mesh's vertices, faces, entities and groups and T's edges, with
/// edge_nodes and face_nodes sized but not yet filled: the frame every node placement fills.
HighOrderMesh high_order_frame(const Mesh& mesh, const Topology& T, int p, NodeDistribution d);

/// Order-p mesh with every high-order node on the straight triangles (the `linear` baseline),
/// at the reference positions of distribution d. Topology T must be build_topology(mesh.F).
HighOrderMesh make_straight_high_order(const Mesh& mesh, const Topology& T, int p,
                                       NodeDistribution d = NodeDistribution::Equispaced);

/// Global 0-based node indices of face f in Gmsh order: vertices [0, #V), then edge nodes
/// [#V, #V + #E(p-1)), then face nodes. Reverses an edge's nodes where the face walks it
/// from E(e,1) to E(e,0).
void element_node_indices(const HighOrderMesh& hm, int f, int* out);

/// Position of global node g (element_node_indices' numbering).
Eigen::Vector3d node_position(const HighOrderMesh& hm, int g);

/// Moves global node g, an edge or face node (not a vertex: the input's corners stay).
void set_node_position(HighOrderMesh& hm, int g, const Eigen::Vector3d& x);

/// Coordinates of face f's nodes in Gmsh order, #nodes x 3.
Eigen::MatrixXd element_nodes(const HighOrderMesh& hm, int f);

/// All nodes stacked in global index order (vertices, edge nodes, face nodes), #nodes x 3.
Eigen::MatrixXd all_nodes(const HighOrderMesh& hm);

}  // namespace hocurve
