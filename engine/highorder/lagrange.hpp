// Lagrange basis of the order-p triangle with equispaced nodes in Gmsh order: the map every
// .msh reader (Gmsh, meshio, ParaView) assumes for element types 2, 9, 21, 23, 25, 42, ...
#pragma once
#include <Eigen/Core>

namespace hocurve {

/// Basis functions of the order-p (1..10) Lagrange triangle at the points uv (#pts x 2,
/// reference coordinates on (0,0),(1,0),(0,1)). Returns #pts x #nodes; column k belongs to
/// node k of triangle_lattice(p). Closed-form product in barycentric lattice coordinates:
/// phi_a(lambda) = prod_c prod_{m < a_c} (p lambda_c - m) / (m + 1).
Eigen::MatrixXd triangle_basis(int p, const Eigen::MatrixXd& uv);

/// Derivatives d phi / du and d phi / dv at the points uv, each #pts x #nodes.
void triangle_basis_gradients(int p, const Eigen::MatrixXd& uv, Eigen::MatrixXd& dU,
                              Eigen::MatrixXd& dV);

/// Positions of the order-p triangle with nodes (#nodes x 3, Gmsh order) at uv: #pts x 3.
Eigen::MatrixXd evaluate_triangle(const Eigen::MatrixXd& nodes, int p, const Eigen::MatrixXd& uv);

/// Tangents x_u and x_v (#pts x 3 each) of the same map.
void evaluate_triangle_tangents(const Eigen::MatrixXd& nodes, int p, const Eigen::MatrixXd& uv,
                                Eigen::MatrixXd& Xu, Eigen::MatrixXd& Xv);

}  // namespace hocurve
