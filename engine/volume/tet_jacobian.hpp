// Certified validity of curved tetrahedra: the Jacobian determinant of an order-p tet is a
// polynomial of degree 3(p-1); its Bernstein coefficients bound it from below (min coefficient)
// and subdividing the tet tightens the bound. A tet is valid when det J > 0 everywhere.
#pragma once
#include <Eigen/Core>
#include <array>

namespace hocurve {

/// Matrices of the bound for one order, built once and shared (no global cache).
/// S = #samples = tet_bernstein_count(d), n = tet_node_count(p).
struct TetJacobianBasis {
  explicit TetJacobianBasis(int p);  ///< p = 1..6
  int p = 1, d = 0;
  Eigen::MatrixXd grad_u, grad_v, grad_w;    ///< S x n: Lagrange gradients at the degree-d lattice
  Eigen::MatrixXd to_bernstein;              ///< S x S: det J at the lattice -> Bernstein coefficients
  std::array<Eigen::MatrixXd, 8> children;   ///< S x S: coefficients on the 8 sub-tets of a uniform split
};

/// det J at the degree-d lattice points (S values) of the tet with nodes X (n x 3, Gmsh order).
Eigen::VectorXd jacobian_samples(const TetJacobianBasis& basis, const Eigen::MatrixXd& X);

struct TetCheckOptions {
  int max_subdivisions = 3;  ///< undecided after this many uniform splits: reported invalid
};

/// Verdict on one tet. Ratios are over det J of the straight tet through its corners (6 x its volume).
struct TetQuality {
  bool valid = false;
  double min_ratio = 0;       ///< certified lower bound of det J / det J_straight (valid: > 0)
  double scaled_jacobian = 0; ///< certified lower bound of min det J / max det J (1 for a straight tet)
  double sampled_scaled_jacobian = 0;  ///< the same from the samples alone (what Gmsh reports; not a bound)
  int depth = 0;              ///< subdivision depth the decision needed
};

/// Checks the tet with nodes X (n x 3): a sample <= 0 proves it invalid; otherwise Bernstein
/// coefficients > 0 prove it valid, on the whole tet or on every sub-tet down to max_subdivisions.
TetQuality check_tet(const TetJacobianBasis& basis, const Eigen::MatrixXd& X, const TetCheckOptions& opt = {});

/// 6 x signed volume of the straight tet through the first four rows of X.
double straight_jacobian(const Eigen::MatrixXd& X);

}  // namespace hocurve
