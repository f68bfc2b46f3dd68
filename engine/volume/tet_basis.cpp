// Closed-form Lagrange basis (products over barycentric lattice coordinates, exact Kronecker
// delta at the nodes) and Bernstein basis on the tetrahedron.
#include "engine/volume/tet_basis.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <cmath>
#include <string>

namespace hocurve {

namespace {

void check_input(int p, const Eigen::MatrixXd& uvw, const char* where) {
  if (p < 0 || p > 10) throw UsageError(std::string(where) + ": order " + std::to_string(p) + " out of range");
  if (uvw.cols() != 3 && uvw.rows() > 0) throw UsageError(std::string(where) + ": points need 3 columns");
}

// f[k] = prod_{m<k} (p l - m)/(m+1), k = 0..p, and its derivative g in l.
void factor_table(int p, double l, double* f, double* g) {
  f[0] = 1;
  g[0] = 0;
  for (int k = 1; k <= p; ++k) {
    const double q = (p * l - (k - 1)) / k;
    f[k] = f[k - 1] * q;
    g[k] = g[k - 1] * q + f[k - 1] * (double(p) / k);
  }
}

// Evaluates the basis (and its gradients when dU is given) at the points.
void lagrange(int p, const Eigen::MatrixXd& uvw, Eigen::MatrixXd* B, Eigen::MatrixXd* dU, Eigen::MatrixXd* dV,
              Eigen::MatrixXd* dW) {
  const Eigen::MatrixXi L = tet_lattice(p);
  const Eigen::Index n = L.rows(), m = uvw.rows();
  if (B) B->resize(m, n);
  if (dU) {
    dU->resize(m, n);
    dV->resize(m, n);
    dW->resize(m, n);
  }
  double f[4][11], g[4][11];
  for (Eigen::Index i = 0; i < m; ++i) {
    const double l[4] = {1 - uvw(i, 0) - uvw(i, 1) - uvw(i, 2), uvw(i, 0), uvw(i, 1), uvw(i, 2)};
    for (int c = 0; c < 4; ++c) factor_table(p, l[c], f[c], g[c]);
    for (Eigen::Index k = 0; k < n; ++k) {
      const int a[4] = {p - L(k, 0) - L(k, 1) - L(k, 2), L(k, 0), L(k, 1), L(k, 2)};
      const double v0 = f[0][a[0]], v1 = f[1][a[1]], v2 = f[2][a[2]], v3 = f[3][a[3]];
      if (B) (*B)(i, k) = v0 * v1 * v2 * v3;
      if (dU) {
        // d l0 / d(u, v, w) = -1; d l_c / d(u, v, w)_c = 1.
        const double d0 = g[0][a[0]] * v1 * v2 * v3;
        (*dU)(i, k) = v0 * g[1][a[1]] * v2 * v3 - d0;
        (*dV)(i, k) = v0 * v1 * g[2][a[2]] * v3 - d0;
        (*dW)(i, k) = v0 * v1 * v2 * g[3][a[3]] - d0;
      }
    }
  }
}

}  // namespace

Eigen::MatrixXd tet_basis(int p, const Eigen::MatrixXd& uvw) {
  check_input(p, uvw, "tet_basis");
  Eigen::MatrixXd B;
  lagrange(p, uvw, &B, nullptr, nullptr, nullptr);
  return B;
}

void tet_basis_gradients(int p, const Eigen::MatrixXd& uvw, Eigen::MatrixXd& dU, Eigen::MatrixXd& dV,
                         Eigen::MatrixXd& dW) {
  check_input(p, uvw, "tet_basis_gradients");
  lagrange(p, uvw, nullptr, &dU, &dV, &dW);
}

Eigen::MatrixXi tet_bernstein_indices(int d) {
  Eigen::MatrixXi A(tet_bernstein_count(d), 3);
  int r = 0;
  for (int a3 = 0; a3 <= d; ++a3)
    for (int a2 = 0; a2 + a3 <= d; ++a2)
      for (int a1 = 0; a1 + a2 + a3 <= d; ++a1) A.row(r++) << a1, a2, a3;
  return A;
}

Eigen::MatrixXd tet_bernstein_matrix(int d, const Eigen::MatrixXd& uvw) {
  check_input(d, uvw, "tet_bernstein_matrix");
  const Eigen::MatrixXi A = tet_bernstein_indices(d);
  double fact[32];
  fact[0] = 1;
  for (int k = 1; k < 32; ++k) fact[k] = fact[k - 1] * k;
  Eigen::MatrixXd B(uvw.rows(), A.rows());
  for (Eigen::Index i = 0; i < uvw.rows(); ++i) {
    const double l[4] = {1 - uvw(i, 0) - uvw(i, 1) - uvw(i, 2), uvw(i, 0), uvw(i, 1), uvw(i, 2)};
    for (Eigen::Index k = 0; k < A.rows(); ++k) {
      const int a[4] = {d - A(k, 0) - A(k, 1) - A(k, 2), A(k, 0), A(k, 1), A(k, 2)};
      double v = fact[d];
      for (int c = 0; c < 4; ++c) v *= std::pow(l[c], a[c]) / fact[a[c]];
      B(i, k) = v;
    }
  }
  return B;
}

Eigen::MatrixXd tet_bernstein_lattice(int d) {
  if (d == 0) return Eigen::RowVector3d::Constant(0.25);
  return tet_bernstein_indices(d).cast<double>() / d;
}

}  // namespace hocurve
