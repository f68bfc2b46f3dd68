#include "engine/highorder/bezier.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/LU>
#include <cmath>
#include <string>

namespace hocurve {

namespace {

void check_degree(int d, const char* where) {
  if (d < 0 || d > 30) throw UsageError(std::string(where) + ": degree " + std::to_string(d) + " out of range 0..30");
}

double factorial(int n) {
  double f = 1;
  for (int k = 2; k <= n; ++k) f *= k;
  return f;
}

// Multinomial |alpha|! / prod alpha_i!.
double multinomial(int a0, int a1, int a2) {
  return factorial(a0 + a1 + a2) / (factorial(a0) * factorial(a1) * factorial(a2));
}

// Integer powers of x, 0..d.
void powers(double x, int d, double* out) {
  out[0] = 1;
  for (int k = 1; k <= d; ++k) out[k] = out[k - 1] * x;
}

}  // namespace

Eigen::MatrixXi bernstein_indices(int d) {
  check_degree(d, "bernstein_indices");
  Eigen::MatrixXi A(bernstein_count(d), 2);
  for (int a2 = 0; a2 <= d; ++a2)
    for (int a1 = 0; a1 + a2 <= d; ++a1) A.row(bernstein_index(d, a1, a2)) << a1, a2;
  return A;
}

Eigen::MatrixXd bernstein_lattice(int d) {
  const Eigen::MatrixXi A = bernstein_indices(d);
  if (d == 0) return Eigen::MatrixXd::Constant(1, 2, 1.0 / 3.0);
  return A.cast<double>() / d;
}

Eigen::MatrixXd bernstein_matrix(int d, const Eigen::MatrixXd& uv) {
  check_degree(d, "bernstein_matrix");
  const Eigen::MatrixXi A = bernstein_indices(d);
  Eigen::MatrixXd T(uv.rows(), A.rows());
  std::vector<double> p0(d + 1), p1(d + 1), p2(d + 1);
  for (Eigen::Index k = 0; k < uv.rows(); ++k) {
    const double u = uv(k, 0), v = uv(k, 1);
    powers(1 - u - v, d, p0.data());
    powers(u, d, p1.data());
    powers(v, d, p2.data());
    for (Eigen::Index m = 0; m < A.rows(); ++m) {
      const int a1 = A(m, 0), a2 = A(m, 1), a0 = d - a1 - a2;
      T(k, m) = multinomial(a0, a1, a2) * p0[a0] * p1[a1] * p2[a2];
    }
  }
  return T;
}

void bernstein_gradient_matrices(int d, const Eigen::MatrixXd& uv, Eigen::MatrixXd& dU,
                                 Eigen::MatrixXd& dV) {
  check_degree(d, "bernstein_gradient_matrices");
  const int n = bernstein_count(d);
  dU = Eigen::MatrixXd::Zero(uv.rows(), n);
  dV = Eigen::MatrixXd::Zero(uv.rows(), n);
  if (d == 0) return;
  // dB^d_alpha/du = d (B^{d-1}_{alpha-e1} - B^{d-1}_{alpha-e0}); likewise for v with e2.
  const Eigen::MatrixXd Tl = bernstein_matrix(d - 1, uv);
  const Eigen::MatrixXi A = bernstein_indices(d);
  for (int m = 0; m < n; ++m) {
    const int a1 = A(m, 0), a2 = A(m, 1), a0 = d - a1 - a2;
    if (a1 > 0) dU.col(m) += d * Tl.col(bernstein_index(d - 1, a1 - 1, a2));
    if (a2 > 0) dV.col(m) += d * Tl.col(bernstein_index(d - 1, a1, a2 - 1));
    if (a0 > 0) {
      dU.col(m) -= d * Tl.col(bernstein_index(d - 1, a1, a2));
      dV.col(m) -= d * Tl.col(bernstein_index(d - 1, a1, a2));
    }
  }
}

Eigen::MatrixXd lagrange_to_bernstein(int p) {
  const Eigen::MatrixXi L = triangle_lattice(p);
  const Eigen::MatrixXd uv = L.cast<double>() / p;
  // T(k, m) = B_m(node k): Lagrange interpolation X = T P, hence P = T^{-1} X.
  const Eigen::MatrixXd T = bernstein_matrix(p, uv);
  return T.fullPivLu().inverse();
}

void bernstein_derivatives(int d, const Eigen::MatrixXd& P, Eigen::MatrixXd& Pu, Eigen::MatrixXd& Pv) {
  check_degree(d, "bernstein_derivatives");
  if (P.rows() != bernstein_count(d))
    throw UsageError("bernstein_derivatives: expected " + std::to_string(bernstein_count(d)) + " coefficients, got " +
                     std::to_string(P.rows()));
  if (d == 0) {
    Pu = Eigen::MatrixXd::Zero(1, P.cols());
    Pv = Pu;
    return;
  }
  Pu.resize(bernstein_count(d - 1), P.cols());
  Pv.resize(bernstein_count(d - 1), P.cols());
  for (int b2 = 0; b2 < d; ++b2)
    for (int b1 = 0; b1 + b2 < d; ++b1) {
      const int i = bernstein_index(d - 1, b1, b2);
      const auto base = P.row(bernstein_index(d, b1, b2));  // beta + e0
      Pu.row(i) = d * (P.row(bernstein_index(d, b1 + 1, b2)) - base);
      Pv.row(i) = d * (P.row(bernstein_index(d, b1, b2 + 1)) - base);
    }
}

BernsteinProduct make_bernstein_product(int a, int b) {
  check_degree(a, "make_bernstein_product");
  check_degree(b, "make_bernstein_product");
  BernsteinProduct prod;
  prod.a = a;
  prod.b = b;
  const Eigen::MatrixXi A = bernstein_indices(a), B = bernstein_indices(b);
  prod.terms.reserve(static_cast<size_t>(A.rows() * B.rows()));
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = 0; j < B.rows(); ++j) {
      const int x1 = A(i, 0), x2 = A(i, 1), x0 = a - x1 - x2;
      const int y1 = B(j, 0), y2 = B(j, 1), y0 = b - y1 - y2;
      const double coef = multinomial(x0, x1, x2) * multinomial(y0, y1, y2) / multinomial(x0 + y0, x1 + y1, x2 + y2);
      prod.terms.push_back({static_cast<int>(i), static_cast<int>(j), bernstein_index(a + b, x1 + y1, x2 + y2), coef});
    }
  return prod;
}

Eigen::VectorXd bernstein_multiply(const BernsteinProduct& prod, const Eigen::VectorXd& f, const Eigen::VectorXd& h) {
  if (f.size() != bernstein_count(prod.a) || h.size() != bernstein_count(prod.b))
    throw UsageError("bernstein_multiply: coefficient counts do not match the product's degrees");
  Eigen::VectorXd c = Eigen::VectorXd::Zero(prod.result_count());
  for (const auto& t : prod.terms) c[t.ig] += t.coef * f[t.ia] * h[t.ib];
  return c;
}

Eigen::Matrix<double, 3, 2> subdivision_child_corners(int c) {
  Eigen::Matrix<double, 3, 2> Q;
  switch (c) {
    case 0: Q << 0, 0, 0.5, 0, 0, 0.5; break;
    case 1: Q << 0.5, 0, 1, 0, 0.5, 0.5; break;
    case 2: Q << 0, 0.5, 0.5, 0.5, 0, 1; break;
    case 3: Q << 0.5, 0.5, 0, 0.5, 0.5, 0; break;
    default: throw UsageError("subdivision_child_corners: child " + std::to_string(c) + " out of range 0..3");
  }
  return Q;
}

Eigen::MatrixXd bernstein_subdivision_matrix(int d, int c) {
  check_degree(d, "bernstein_subdivision_matrix");
  const Eigen::Matrix<double, 3, 2> Q = subdivision_child_corners(c);
  // Barycentrics of the child's corners in the parent.
  double lam[3][3];
  for (int k = 0; k < 3; ++k) {
    lam[k][0] = 1 - Q(k, 0) - Q(k, 1);
    lam[k][1] = Q(k, 0);
    lam[k][2] = Q(k, 1);
  }
  const int n = bernstein_count(d);
  Eigen::MatrixXd S(n, n);
  const Eigen::MatrixXi G = bernstein_indices(d);
  // Child coefficient gamma = blossom of f at (q0^g0, q1^g1, q2^g2): d de Casteljau steps,
  // each with one child corner. Tracked as rows of weights on the parent coefficients; with
  // corners at barycentrics 0, 1/2, 1 every weight is a dyadic rational, so S is exact.
  for (int g = 0; g < n; ++g) {
    const int g1 = G(g, 0), g2 = G(g, 1), g0 = d - g1 - g2;
    int seq[64];
    int len = 0;
    for (int k = 0; k < g0; ++k) seq[len++] = 0;
    for (int k = 0; k < g1; ++k) seq[len++] = 1;
    for (int k = 0; k < g2; ++k) seq[len++] = 2;
    Eigen::MatrixXd W = Eigen::MatrixXd::Identity(n, n);  // row r: coefficient r of the current degree
    for (int r = d; r > 0; --r) {
      const double* l = lam[seq[d - r]];
      Eigen::MatrixXd Wn(bernstein_count(r - 1), n);
      for (int b2 = 0; b2 < r; ++b2)
        for (int b1 = 0; b1 + b2 < r; ++b1)
          Wn.row(bernstein_index(r - 1, b1, b2)) = l[0] * W.row(bernstein_index(r, b1, b2)) +
                                                   l[1] * W.row(bernstein_index(r, b1 + 1, b2)) +
                                                   l[2] * W.row(bernstein_index(r, b1, b2 + 1));
      W.swap(Wn);
    }
    S.row(g) = W.row(0);
  }
  return S;
}

}  // namespace hocurve
