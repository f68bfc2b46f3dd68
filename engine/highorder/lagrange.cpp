// Closed-form Lagrange basis of the equispaced triangle (no Vandermonde inverse: exact
// Kronecker delta at the nodes and O(p) work per function).
#include "engine/highorder/lagrange.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <string>

namespace hocurve {

namespace {

void check_input(int p, const Eigen::MatrixXd& uv, const char* where) {
  if (p < 1 || p > 10)
    throw UsageError(std::string(where) + ": order " + std::to_string(p) + " out of range 1..10");
  if (uv.cols() != 2 && uv.rows() > 0)
    throw UsageError(std::string(where) + ": uv must have 2 columns, got " + std::to_string(uv.cols()));
}

// For one barycentric coordinate l: f[k] = prod_{m<k} (p l - m)/(m+1) (k = 0..p) and, when
// g is given, its derivative in l.
void factor_table(int p, double l, double* f, double* g) {
  const double s = p * l;
  f[0] = 1;
  if (g) g[0] = 0;
  for (int k = 1; k <= p; ++k) {
    const double q = (s - (k - 1)) / k;
    f[k] = f[k - 1] * q;
    if (g) g[k] = g[k - 1] * q + f[k - 1] * (double(p) / k);
  }
}

// Barycentric lattice indices (a0, a1, a2) of the nodes, Gmsh order.
Eigen::MatrixXi barycentric_indices(int p) {
  const Eigen::MatrixXi L = triangle_lattice(p);
  Eigen::MatrixXi A(L.rows(), 3);
  for (Eigen::Index k = 0; k < L.rows(); ++k) A.row(k) << p - L(k, 0) - L(k, 1), L(k, 0), L(k, 1);
  return A;
}

}  // namespace

Eigen::MatrixXd triangle_basis(int p, const Eigen::MatrixXd& uv) {
  check_input(p, uv, "triangle_basis");
  const Eigen::MatrixXi A = barycentric_indices(p);
  Eigen::MatrixXd B(uv.rows(), A.rows());
  double f[3][11];
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double l[3] = {1 - uv(i, 0) - uv(i, 1), uv(i, 0), uv(i, 1)};
    for (int c = 0; c < 3; ++c) factor_table(p, l[c], f[c], nullptr);
    for (Eigen::Index k = 0; k < A.rows(); ++k) B(i, k) = f[0][A(k, 0)] * f[1][A(k, 1)] * f[2][A(k, 2)];
  }
  return B;
}

void triangle_basis_gradients(int p, const Eigen::MatrixXd& uv, Eigen::MatrixXd& dU,
                              Eigen::MatrixXd& dV) {
  check_input(p, uv, "triangle_basis_gradients");
  const Eigen::MatrixXi A = barycentric_indices(p);
  dU.resize(uv.rows(), A.rows());
  dV.resize(uv.rows(), A.rows());
  double f[3][11], g[3][11];
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double l[3] = {1 - uv(i, 0) - uv(i, 1), uv(i, 0), uv(i, 1)};
    for (int c = 0; c < 3; ++c) factor_table(p, l[c], f[c], g[c]);
    for (Eigen::Index k = 0; k < A.rows(); ++k) {
      const double f0 = f[0][A(k, 0)], f1 = f[1][A(k, 1)], f2 = f[2][A(k, 2)];
      const double d0 = g[0][A(k, 0)] * f1 * f2;  // d/d lambda_0
      // lambda_0 = 1 - u - v, lambda_1 = u, lambda_2 = v.
      dU(i, k) = f0 * g[1][A(k, 1)] * f2 - d0;
      dV(i, k) = f0 * f1 * g[2][A(k, 2)] - d0;
    }
  }
}

Eigen::MatrixXd evaluate_triangle(const Eigen::MatrixXd& nodes, int p, const Eigen::MatrixXd& uv) {
  if (nodes.rows() != triangle_node_count(p))
    throw UsageError("evaluate_triangle: " + std::to_string(nodes.rows()) + " nodes for order " +
                     std::to_string(p) + " (expected " + std::to_string(triangle_node_count(p)) + ")");
  return triangle_basis(p, uv) * nodes;
}

void evaluate_triangle_tangents(const Eigen::MatrixXd& nodes, int p, const Eigen::MatrixXd& uv,
                                Eigen::MatrixXd& Xu, Eigen::MatrixXd& Xv) {
  if (nodes.rows() != triangle_node_count(p))
    throw UsageError("evaluate_triangle_tangents: " + std::to_string(nodes.rows()) +
                     " nodes for order " + std::to_string(p));
  Eigen::MatrixXd dU, dV;
  triangle_basis_gradients(p, uv, dU, dV);
  Xu = dU * nodes;
  Xv = dV * nodes;
}

}  // namespace hocurve
