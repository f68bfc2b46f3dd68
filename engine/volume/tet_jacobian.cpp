// Jacobian bounds of curved tets by sampling det J at the degree-3(p-1) lattice and converting
// to Bernstein form (exact: det J is a polynomial of that degree).
#include "engine/volume/tet_jacobian.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"
#include "engine/volume/tet_basis.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <limits>
#include <string>

namespace hocurve {

namespace {

// Corners (barycentric, as uvw) of the 8 children of the uniform split: 4 corner tets and the
// inner octahedron cut along its diagonal m02-m13 into 4.
std::array<Eigen::Matrix<double, 4, 3>, 8> child_corners() {
  const Eigen::RowVector3d v[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  auto m = [&](int a, int b) -> Eigen::RowVector3d { return 0.5 * (v[a] + v[b]); };
  const Eigen::RowVector3d m01 = m(0, 1), m02 = m(0, 2), m03 = m(0, 3), m12 = m(1, 2), m13 = m(1, 3), m23 = m(2, 3);
  const Eigen::RowVector3d c[8][4] = {{v[0], m01, m02, m03}, {m01, v[1], m12, m13}, {m02, m12, v[2], m23},
                                      {m03, m13, m23, v[3]}, {m01, m02, m03, m13}, {m01, m02, m13, m12},
                                      {m02, m03, m13, m23},  {m02, m12, m23, m13}};
  std::array<Eigen::Matrix<double, 4, 3>, 8> out;
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 4; ++j) out[k].row(j) = c[k][j];
  return out;
}

// Min coefficient over the sub-tets down to max_level (deepest: the level reached). Stops at
// the first leaf that stays undecided: the tet is then reported invalid anyway.
double lower_bound(const TetJacobianBasis& b, const Eigen::VectorXd& coef, int level, int max_level, int& deepest) {
  const double lo = coef.minCoeff();
  if (lo > 0 || level == max_level) return lo;
  deepest = std::max(deepest, level + 1);
  double out = std::numeric_limits<double>::infinity();
  for (const Eigen::MatrixXd& S : b.children) {
    out = std::min(out, lower_bound(b, S * coef, level + 1, max_level, deepest));
    if (out <= 0) break;
  }
  return out;
}

}  // namespace

TetJacobianBasis::TetJacobianBasis(int p_) : p(p_), d(3 * (p_ - 1)) {
  if (p < 1 || p > 6) throw UsageError("TetJacobianBasis: order " + std::to_string(p) + " out of range 1..6");
  const Eigen::MatrixXd lattice = tet_bernstein_lattice(d);
  tet_basis_gradients(p, lattice, grad_u, grad_v, grad_w);
  to_bernstein = tet_bernstein_matrix(d, lattice).inverse();
  const auto corners = child_corners();
  for (int k = 0; k < 8; ++k) {
    // Child lattice points in the parent's coordinates: the child's values there, converted.
    const Eigen::MatrixXd& C = corners[k];
    Eigen::MatrixXd pts(lattice.rows(), 3);
    for (Eigen::Index i = 0; i < lattice.rows(); ++i) {
      const double l[4] = {1 - lattice.row(i).sum(), lattice(i, 0), lattice(i, 1), lattice(i, 2)};
      pts.row(i) = l[0] * C.row(0) + l[1] * C.row(1) + l[2] * C.row(2) + l[3] * C.row(3);
    }
    children[k] = to_bernstein * tet_bernstein_matrix(d, pts);
  }
}

Eigen::VectorXd jacobian_samples(const TetJacobianBasis& b, const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd Xu = b.grad_u * X, Xv = b.grad_v * X, Xw = b.grad_w * X;
  Eigen::VectorXd J(Xu.rows());
  for (Eigen::Index s = 0; s < J.size(); ++s) {
    const Eigen::RowVector3d u = Xu.row(s), v = Xv.row(s), w = Xw.row(s);
    J[s] = u.dot(v.cross(w));
  }
  return J;
}

double straight_jacobian(const Eigen::MatrixXd& X) {
  const Eigen::RowVector3d a = X.row(0), b = X.row(1) - a, c = X.row(2) - a, d = X.row(3) - a;
  return b.dot(c.cross(d));
}

TetQuality check_tet(const TetJacobianBasis& b, const Eigen::MatrixXd& X, const TetCheckOptions& opt) {
  TetQuality q;
  const Eigen::VectorXd J = jacobian_samples(b, X);
  const double j0 = std::abs(straight_jacobian(X)), jmax = J.maxCoeff();
  const double scale = j0 > 0 ? j0 : std::max(std::abs(jmax), std::numeric_limits<double>::min());
  q.sampled_scaled_jacobian = jmax > 0 ? J.minCoeff() / jmax : -1;
  if (J.minCoeff() <= 0) {  // a point with det J <= 0: certainly invalid
    q.min_ratio = J.minCoeff() / scale;
    q.scaled_jacobian = q.sampled_scaled_jacobian;
    return q;
  }
  const Eigen::VectorXd coef = b.to_bernstein * J;
  const double lo = lower_bound(b, coef, 0, opt.max_subdivisions, q.depth);
  q.valid = lo > 0;
  q.min_ratio = lo / scale;
  q.scaled_jacobian = lo / jmax;
  return q;
}

}  // namespace hocurve
