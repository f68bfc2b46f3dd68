// Bernstein (Bezier) polynomials on the reference triangle (0,0),(1,0),(0,1): evaluation,
// Lagrange -> Bernstein conversion, derivative nets, exact products and subdivision.
// Used to bound the Jacobian determinant of curved triangles (validity.hpp).
//
// Barycentrics: l0 = 1 - u - v, l1 = u, l2 = v. A degree-d multi-index is (a0, a1, a2) with
// a0 + a1 + a2 = d; it is stored as its (a1, a2) and numbered "a2 outer, a1 inner":
// index(a1, a2) = a2 (d + 1) - a2 (a2 - 1) / 2 + a1. This is NOT Gmsh's node order.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace hocurve {

/// Number of degree-d Bernstein polynomials on the triangle, (d+1)(d+2)/2.
inline int bernstein_count(int d) { return (d + 1) * (d + 2) / 2; }

/// Position of the multi-index (a1, a2) (a0 = d - a1 - a2) in the Bernstein numbering.
inline int bernstein_index(int d, int a1, int a2) { return a2 * (d + 1) - a2 * (a2 - 1) / 2 + a1; }

/// Multi-indices of degree d in Bernstein numbering: row m = (a1, a2).
Eigen::MatrixXi bernstein_indices(int d);

/// The degree-d lattice points (a1/d, a2/d) in Bernstein numbering, #count x 2 (d = 0: the centroid).
Eigen::MatrixXd bernstein_lattice(int d);

/// Values of every degree-d Bernstein polynomial at the points uv (#pts x 2): #pts x #count.
Eigen::MatrixXd bernstein_matrix(int d, const Eigen::MatrixXd& uv);

/// d/du and d/dv of every degree-d Bernstein polynomial at the points uv, each #pts x #count.
void bernstein_gradient_matrices(int d, const Eigen::MatrixXd& uv, Eigen::MatrixXd& dU,
                                 Eigen::MatrixXd& dV);

/// Lagrange -> Bernstein conversion of the order-p equispaced Lagrange triangle with nodes in
/// Gmsh order (triangle_lattice(p)): control points P = M * X, where X is #nodes x k in Gmsh
/// order and P is #count x k in Bernstein numbering. M is the inverse of the Bernstein basis
/// sampled at the nodes.
Eigen::MatrixXd lagrange_to_bernstein(int p);

/// Derivative nets of a degree-d polynomial with coefficients P (#count(d) x k): coefficients
/// (degree d-1) of d/du and d/dv. D_u[b] = d (P[b + e1] - P[b + e0]), D_v with e2.
void bernstein_derivatives(int d, const Eigen::MatrixXd& P, Eigen::MatrixXd& Pu, Eigen::MatrixXd& Pv);

/// Exact product of two Bernstein polynomials of degrees a and b, as a precomputed list of
/// terms: c[g] += coef * f[ia] * h[ib] with g the index of alpha + beta and
/// coef = C(alpha) C(beta) / C(alpha + beta), C(alpha) = |alpha|! / prod alpha_i!.
struct BernsteinProduct {
  struct Term {
    int ia, ib, ig;
    double coef;
  };
  int a = 0, b = 0;
  std::vector<Term> terms;
  int result_count() const { return bernstein_count(a + b); }
};

/// Builds the product table for degrees a and b.
BernsteinProduct make_bernstein_product(int a, int b);

/// Coefficients (degree a + b) of the product of f (degree a) and h (degree b).
Eigen::VectorXd bernstein_multiply(const BernsteinProduct& prod, const Eigen::VectorXd& f,
                                   const Eigen::VectorXd& h);

/// Corners (u, v) of child c (0..3) of the reference triangle split at its edge midpoints:
/// 0, 1, 2 keep corner 0, 1, 2; 3 is the middle triangle. Returns 3 x 2.
Eigen::Matrix<double, 3, 2> subdivision_child_corners(int c);

/// Subdivision matrix S_c (#count x #count): the degree-d coefficients of f restricted to child c
/// (reparametrised on the reference triangle by the child's corners) are S_c * coefficients of f.
Eigen::MatrixXd bernstein_subdivision_matrix(int d, int c);

}  // namespace hocurve
