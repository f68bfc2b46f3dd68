// Reference nodes of Lagrange triangles and tetrahedra in Gmsh 4.8's exact node order.
#pragma once
#include <Eigen/Core>
#include <string>

namespace hocurve {

/// Where the nodes sit inside an element. Gmsh's Lagrange elements assume equispaced nodes.
enum class NodeDistribution { Equispaced, Lobatto };
const char* to_string(NodeDistribution d);
/// Parses "equispaced" or "lobatto"; throws UsageError otherwise.
NodeDistribution parse_node_distribution(const std::string& s);

/// Gmsh element type of the complete Lagrange triangle of order p (1..10): 2, 9, 21, 23, 25, 42, ...
int gmsh_triangle_type(int p);
/// Gmsh element type of the complete Lagrange tetrahedron of order p (1..10): 4, 11, 29, 30, ...
int gmsh_tet_type(int p);
/// Number of nodes of a triangle (p+1)(p+2)/2 and of a tet (p+1)(p+2)(p+3)/6.
int triangle_node_count(int p);
int tet_node_count(int p);

/// Integer lattice of the order-p triangle in Gmsh order: row k = (i, j), (u, v) = (i, j) / p.
Eigen::MatrixXi triangle_lattice(int p);
/// Integer lattice of the order-p tet in Gmsh order: row k = (i, j, l), (u, v, w) = (i, j, l) / p.
Eigen::MatrixXi tet_lattice(int p);

/// Reference (u, v) of the order-p triangle's nodes, Gmsh order, #nodes x 2.
/// Lobatto: Gauss-Lobatto-Legendre points on the edges, warp & blend inside.
Eigen::MatrixXd triangle_reference_nodes(int p, NodeDistribution d = NodeDistribution::Equispaced);
/// Reference (u, v, w) of the order-p tet's nodes, Gmsh order, #nodes x 3.
/// Lobatto: every face holds exactly the Lobatto triangle's nodes (so tets conform to Lobatto
/// surface triangles); interior nodes get Warburton's blended face warps.
Eigen::MatrixXd tet_reference_nodes(int p, NodeDistribution d = NodeDistribution::Equispaced);

/// The p+1 points of a 1D distribution on [0, 1], ascending (ends included). Lobatto: the
/// Gauss-Lobatto-Legendre points (Newton on P'_p), exactly symmetric: t[p-k] == 1 - t[k].
Eigen::VectorXd line_reference_nodes(int p, NodeDistribution d = NodeDistribution::Equispaced);

}  // namespace hocurve
