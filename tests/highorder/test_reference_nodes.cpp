// Reference nodes against Gmsh's own element tables, and the Lobatto distribution's properties.
#include "engine/highorder/reference_nodes.hpp"

#include "engine/core/error.hpp"

#include <doctest/doctest.h>
#include <gmsh.h>
#include "gmsh_session.hpp"
#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

using namespace hocurve;

namespace {


// Gmsh's reference coordinates of an element type, #nodes x dim.
Eigen::MatrixXd gmsh_reference(int type, int dim, int& order, int& nnodes) {
  std::string name;
  int edim, nprim;
  std::vector<double> coord;
  gmsh::model::mesh::getElementProperties(type, name, edim, order, nnodes, coord, nprim);
  REQUIRE(edim == dim);
  REQUIRE(coord.size() == static_cast<size_t>(nnodes * dim));
  Eigen::MatrixXd X(nnodes, dim);
  for (int k = 0; k < nnodes; ++k)
    for (int d = 0; d < dim; ++d) X(k, d) = coord[k * dim + d];
  return X;
}

// The 1D Legendre derivative P'_p(x) computed independently (explicit power-series sum), to
// verify the GLL points are its roots.
double legendre_derivative(int p, double x) {
  // P_p(x) = 2^-p sum_k (-1)^k C(p,k) C(2p-2k,p) x^(p-2k)
  double s = 0;
  auto binom = [](int n, int k) {
    double r = 1;
    for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
    return r;
  };
  for (int k = 0; 2 * k <= p; ++k) {
    const int e = p - 2 * k;
    if (e == 0) continue;
    s += ((k % 2) ? -1.0 : 1.0) * binom(p, k) * binom(2 * p - 2 * k, p) * e * std::pow(x, e - 1);
  }
  return s / std::pow(2.0, p);
}

}  // namespace

TEST_CASE("Gmsh element types and node counts") {
  GmshSession g;
  for (int p = 1; p <= 10; ++p) {
    CHECK(gmsh_triangle_type(p) == gmsh::model::mesh::getElementType("Triangle", p));
    CHECK(gmsh_tet_type(p) == gmsh::model::mesh::getElementType("Tetrahedron", p));
    CHECK(triangle_node_count(p) == triangle_lattice(p).rows());
    CHECK(tet_node_count(p) == tet_lattice(p).rows());
  }
  CHECK_THROWS_AS(gmsh_triangle_type(0), UsageError);
  CHECK_THROWS_AS(triangle_lattice(11), UsageError);
  CHECK(parse_node_distribution("lobatto") == NodeDistribution::Lobatto);
  CHECK(std::string(to_string(NodeDistribution::Equispaced)) == "equispaced");
  CHECK_THROWS_AS(parse_node_distribution("chebyshev"), UsageError);
}

TEST_CASE("triangle and tet tables equal Gmsh's reference coordinates") {
  GmshSession g;
  for (int p = 1; p <= 10; ++p) {
    int order, n;
    const Eigen::MatrixXd G = gmsh_reference(gmsh_triangle_type(p), 2, order, n);
    CHECK(order == p);
    const Eigen::MatrixXd X = triangle_reference_nodes(p);
    REQUIRE(X.rows() == n);
    CHECK((X - G).cwiseAbs().maxCoeff() < 1e-14);
    const Eigen::MatrixXi L = triangle_lattice(p);
    CHECK((L.cast<double>() / p - G).cwiseAbs().maxCoeff() < 1e-14);
  }
  for (int p = 1; p <= 10; ++p) {
    int order, n;
    const Eigen::MatrixXd G = gmsh_reference(gmsh_tet_type(p), 3, order, n);
    CHECK(order == p);
    const Eigen::MatrixXd X = tet_reference_nodes(p);
    REQUIRE(X.rows() == n);
    CAPTURE(p);
    CHECK((X - G).cwiseAbs().maxCoeff() < 1e-14);
  }
}

TEST_CASE("Lobatto line nodes are Gauss-Lobatto-Legendre points") {
  for (int p = 1; p <= 10; ++p) {
    const Eigen::VectorXd t = line_reference_nodes(p, NodeDistribution::Lobatto);
    REQUIRE(t.size() == p + 1);
    CHECK(t[0] == 0.0);
    CHECK(t[p] == 1.0);
    for (int k = 0; k < p; ++k) CHECK(t[k] < t[k + 1]);
    for (int k = 0; k <= p; ++k) CHECK(t[k] + t[p - k] == doctest::Approx(1.0).epsilon(1e-15));
    for (int k = 1; k < p; ++k) CHECK(std::abs(legendre_derivative(p, 2 * t[k] - 1)) < 1e-11);
    // p+1 GLL points integrate polynomials of degree 2p-1 exactly with the weights
    // 2 / (p(p+1) P_p(x)^2); here we check instead that interior points are distinct roots.
  }
  // Known closed forms: p = 3 -> +-1/sqrt(5); p = 4 -> 0, +-sqrt(3/7).
  const Eigen::VectorXd t3 = line_reference_nodes(3, NodeDistribution::Lobatto);
  CHECK(2 * t3[1] - 1 == doctest::Approx(-1 / std::sqrt(5.0)).epsilon(1e-15));
  const Eigen::VectorXd t4 = line_reference_nodes(4, NodeDistribution::Lobatto);
  CHECK(2 * t4[2] - 1 == doctest::Approx(0.0));
  CHECK(2 * t4[3] - 1 == doctest::Approx(std::sqrt(3.0 / 7.0)).epsilon(1e-15));
  // Equispaced line.
  const Eigen::VectorXd e = line_reference_nodes(4);
  for (int k = 0; k <= 4; ++k) CHECK(e[k] == k / 4.0);
}

TEST_CASE("Lobatto triangle nodes") {
  for (int p = 1; p <= 10; ++p) {
    CAPTURE(p);
    const Eigen::MatrixXd X = triangle_reference_nodes(p, NodeDistribution::Lobatto);
    const Eigen::MatrixXi L = triangle_lattice(p);
    const Eigen::VectorXd t = line_reference_nodes(p, NodeDistribution::Lobatto);
    REQUIRE(X.rows() == L.rows());
    if (p <= 2) CHECK((X - triangle_reference_nodes(p)).cwiseAbs().maxCoeff() == 0.0);
    const double A[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    for (int k = 0; k < X.rows(); ++k) {
      const int li[3] = {p - L(k, 0) - L(k, 1), L(k, 0), L(k, 1)};
      const double u = X(k, 0), v = X(k, 1);
      const bool on_edge = li[0] == 0 || li[1] == 0 || li[2] == 0;
      if (on_edge) {
        // Edge nodes are the 1D GLL points, whichever way the edge is walked.
        for (int c = 0; c < 3; ++c) {
          if (li[c] != 0) continue;
          const int a = (c + 1) % 3, b = (c + 2) % 3;
          const double s = t[li[b]];
          CHECK(u == doctest::Approx(A[a][0] + s * (A[b][0] - A[a][0])).epsilon(1e-15));
          CHECK(v == doctest::Approx(A[a][1] + s * (A[b][1] - A[a][1])).epsilon(1e-15));
        }
      } else {
        // Strictly inside.
        CHECK(u > 1e-3);
        CHECK(v > 1e-3);
        CHECK(1 - u - v > 1e-3);
      }
    }
    // Symmetry under every vertex permutation: the permuted node set equals the node set.
    const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    for (auto& s : perms) {
      double worst = 0;
      for (int k = 0; k < X.rows(); ++k) {
        const double lam[3] = {1 - X(k, 0) - X(k, 1), X(k, 0), X(k, 1)};
        // Image of node k when vertex i is sent to vertex s[i].
        double mu[3];
        for (int i = 0; i < 3; ++i) mu[s[i]] = lam[i];
        double best = 1e300;
        for (int m = 0; m < X.rows(); ++m)
          best = std::min(best, std::hypot(X(m, 0) - mu[1], X(m, 1) - mu[2]));
        worst = std::max(worst, best);
      }
      CHECK(worst < 1e-14);
    }
    // Nodes are distinct (min distance well above zero).
    double dmin = 1e300;
    for (int i = 0; i < X.rows(); ++i)
      for (int j = i + 1; j < X.rows(); ++j)
        dmin = std::min(dmin, std::hypot(X(i, 0) - X(j, 0), X(i, 1) - X(j, 1)));
    CHECK(dmin > 0.2 / (p * p));
  }
}

namespace {

// Lebesgue constant of a node set (monomial Vandermonde, independent of our Lagrange code),
// sampled on a fine lattice of the reference simplex (dim 2 or 3).
double lebesgue_constant(const Eigen::MatrixXd& X, int p) {
  const int dim = static_cast<int>(X.cols());
  std::vector<std::array<int, 3>> mono;
  for (int a = 0; a <= p; ++a)
    for (int b = 0; a + b <= p; ++b)
      for (int c = 0; a + b + c <= p && (dim == 3 || c == 0); ++c) mono.push_back({a, b, c});
  REQUIRE(mono.size() == static_cast<size_t>(X.rows()));
  auto row = [&](const double* x) {
    Eigen::RowVectorXd r(mono.size());
    for (size_t m = 0; m < mono.size(); ++m)
      r[m] = std::pow(x[0], mono[m][0]) * std::pow(x[1], mono[m][1]) * (dim == 3 ? std::pow(x[2], mono[m][2]) : 1.0);
    return r;
  };
  Eigen::MatrixXd Vd(X.rows(), X.rows());
  for (int i = 0; i < X.rows(); ++i) {
    const double x[3] = {X(i, 0), X(i, 1), dim == 3 ? X(i, 2) : 0.0};
    Vd.row(i) = row(x);
  }
  // Columns: Lagrange basis coefficients. Not Vd.inverse(): libgmsh exports its own
  // PartialPivLU instantiation, and under ASan Eigen switches to a different aligned malloc,
  // so the two copies would free each other's memory (bad-free in HOCURVE_SANITIZE builds).
  const Eigen::MatrixXd C =
      Vd.colPivHouseholderQr().solve(Eigen::MatrixXd::Identity(X.rows(), X.rows()));
  const int n = dim == 3 ? 24 : 60;
  double best = 0;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j)
      for (int k = 0; i + j + k <= n && (dim == 3 || k == 0); ++k) {
        const double x[3] = {double(i) / n, double(j) / n, double(k) / n};
        best = std::max(best, (row(x) * C).cwiseAbs().sum());
      }
  return best;
}

}  // namespace

TEST_CASE("Lobatto nodes have smaller Lebesgue constants than equispaced ones") {
  for (int p : {4, 6, 8}) {
    CAPTURE(p);
    const double eq = lebesgue_constant(triangle_reference_nodes(p), p);
    const double lo = lebesgue_constant(triangle_reference_nodes(p, NodeDistribution::Lobatto), p);
    INFO("triangle p=" << p << " Lebesgue equispaced " << eq << " lobatto " << lo);
    CHECK(lo < eq);
    if (p == 8) CHECK(lo < 0.5 * eq);
  }
  for (int p : {4, 6}) {
    CAPTURE(p);
    const double eq = lebesgue_constant(tet_reference_nodes(p), p);
    const double lo = lebesgue_constant(tet_reference_nodes(p, NodeDistribution::Lobatto), p);
    INFO("tet p=" << p << " Lebesgue equispaced " << eq << " lobatto " << lo);
    CHECK(lo < eq);
  }
}

TEST_CASE("Lobatto tet nodes") {
  for (int p = 1; p <= 10; ++p) {
    CAPTURE(p);
    const Eigen::MatrixXd X = tet_reference_nodes(p, NodeDistribution::Lobatto);
    const Eigen::MatrixXi L = tet_lattice(p);
    REQUIRE(X.rows() == L.rows());
    if (p <= 2) CHECK((X - tet_reference_nodes(p)).cwiseAbs().maxCoeff() == 0.0);
    // Face nodes are the Lobatto triangle's nodes: compare node sets per face.
    const Eigen::MatrixXd T = triangle_reference_nodes(p, NodeDistribution::Lobatto);
    const double V[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const int faces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};  // face opposite vertex a
    for (int a = 0; a < 4; ++a) {
      double worst = 0;
      int on_face = 0;
      for (int k = 0; k < X.rows(); ++k) {
        const double lam[4] = {1 - X(k, 0) - X(k, 1) - X(k, 2), X(k, 0), X(k, 1), X(k, 2)};
        const int li[4] = {p - L(k, 0) - L(k, 1) - L(k, 2), L(k, 0), L(k, 1), L(k, 2)};
        if (li[a] != 0) continue;
        ++on_face;
        CHECK(std::abs(lam[a]) < 1e-15);
        double best = 1e300;
        for (int m = 0; m < T.rows(); ++m) {
          const double w[3] = {1 - T(m, 0) - T(m, 1), T(m, 0), T(m, 1)};
          double dist = 0;
          for (int d = 0; d < 3; ++d) {
            double y = 0;
            for (int c = 0; c < 3; ++c) y += w[c] * V[faces[a][c]][d];
            dist = std::max(dist, std::abs(y - X(k, d)));
          }
          best = std::min(best, dist);
        }
        worst = std::max(worst, best);
      }
      CHECK(on_face == triangle_node_count(p));
      CHECK(worst < 1e-15);
    }
    // Interior nodes strictly inside; the set is invariant under all 24 vertex permutations.
    for (int k = 0; k < X.rows(); ++k) {
      const int li[4] = {p - L(k, 0) - L(k, 1) - L(k, 2), L(k, 0), L(k, 1), L(k, 2)};
      if (li[0] && li[1] && li[2] && li[3]) {
        CHECK(X.row(k).minCoeff() > 1e-3);
        CHECK(1 - X.row(k).sum() > 1e-3);
      }
    }
    int perm[4] = {0, 1, 2, 3};
    double worst = 0;
    do {
      for (int k = 0; k < X.rows(); ++k) {
        const double lam[4] = {1 - X(k, 0) - X(k, 1) - X(k, 2), X(k, 0), X(k, 1), X(k, 2)};
        double mu[4];
        for (int i = 0; i < 4; ++i) mu[perm[i]] = lam[i];
        double best = 1e300;
        for (int m = 0; m < X.rows(); ++m)
          best = std::min(best, (X.row(m) - Eigen::RowVector3d(mu[1], mu[2], mu[3])).cwiseAbs().maxCoeff());
        worst = std::max(worst, best);
      }
    } while (std::next_permutation(perm, perm + 4));
    CHECK(worst < 1e-14);
    double dmin = 1e300;
    for (int i = 0; i < X.rows(); ++i)
      for (int j = i + 1; j < X.rows(); ++j) dmin = std::min(dmin, (X.row(i) - X.row(j)).norm());
    CHECK(dmin > 0.2 / (p * p));
  }
}
