// Polynomial bases on the reference tetrahedron (0,0,0),(1,0,0),(0,1,0),(0,0,1): the order-p
// Lagrange basis in Gmsh's node order (what .msh readers assume for types 4, 11, 29, 30) and
// the degree-d Bernstein basis that bounds a polynomial by its coefficients.
// Barycentrics: l0 = 1 - u - v - w, l1 = u, l2 = v, l3 = w.
#pragma once
#include <Eigen/Core>

namespace hocurve {

/// Basis functions of the order-p (1..10) Lagrange tet at the points uvw (#pts x 3):
/// #pts x #nodes, column k for node k of tet_lattice(p).
Eigen::MatrixXd tet_basis(int p, const Eigen::MatrixXd& uvw);

/// d/du, d/dv, d/dw of the same functions at uvw, each #pts x #nodes.
void tet_basis_gradients(int p, const Eigen::MatrixXd& uvw, Eigen::MatrixXd& dU, Eigen::MatrixXd& dV,
                         Eigen::MatrixXd& dW);

/// Number of degree-d Bernstein polynomials on the tet, (d+1)(d+2)(d+3)/6.
inline int tet_bernstein_count(int d) { return (d + 1) * (d + 2) * (d + 3) / 6; }

/// Multi-indices (a1, a2, a3) (a0 = d - a1 - a2 - a3) of degree d in the numbering every
/// tet Bernstein array here uses: #count x 3.
Eigen::MatrixXi tet_bernstein_indices(int d);

/// Values of every degree-d Bernstein polynomial at uvw (#pts x 3): #pts x #count.
Eigen::MatrixXd tet_bernstein_matrix(int d, const Eigen::MatrixXd& uvw);

/// The degree-d lattice points (a1, a2, a3) / d in Bernstein numbering, #count x 3 (d = 0: the centroid).
Eigen::MatrixXd tet_bernstein_lattice(int d);

}  // namespace hocurve
