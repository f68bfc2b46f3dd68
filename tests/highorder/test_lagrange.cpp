// Lagrange triangle basis against Gmsh's own basis functions.
#include "engine/highorder/lagrange.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <doctest/doctest.h>
#include <gmsh.h>
#include "gmsh_session.hpp"

#include <random>
#include <vector>

using namespace hocurve;

namespace {


// Random points in the reference triangle plus a few on its boundary.
Eigen::MatrixXd sample_points(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  Eigen::MatrixXd uv(n + 3, 2);
  for (int i = 0; i < n; ++i) {
    double u = U(rng), v = U(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    uv.row(i) << u, v;
  }
  uv.row(n) << 0.3, 0.0;
  uv.row(n + 1) << 0.0, 0.85;
  uv.row(n + 2) << 0.4, 0.6;
  return uv;
}

}  // namespace

TEST_CASE("basis and gradients equal Gmsh's Lagrange / GradLagrange") {
  GmshSession g;
  const Eigen::MatrixXd uv = sample_points(40, 7);
  std::vector<double> local;
  for (int i = 0; i < uv.rows(); ++i) local.insert(local.end(), {uv(i, 0), uv(i, 1), 0.0});
  for (int p = 1; p <= 6; ++p) {
    CAPTURE(p);
    const int type = gmsh_triangle_type(p);
    const int n = triangle_node_count(p);
    int ncomp = 0, norient = 0;
    std::vector<double> bf;
    gmsh::model::mesh::getBasisFunctions(type, local, "Lagrange", ncomp, bf, norient);
    REQUIRE(ncomp == 1);
    REQUIRE(bf.size() == static_cast<size_t>(uv.rows() * n));
    const Eigen::MatrixXd B = triangle_basis(p, uv);
    double err = 0;
    for (int i = 0; i < uv.rows(); ++i)
      for (int k = 0; k < n; ++k) err = std::max(err, std::abs(B(i, k) - bf[i * n + k]));
    CHECK(err < 1e-10);

    gmsh::model::mesh::getBasisFunctions(type, local, "GradLagrange", ncomp, bf, norient);
    REQUIRE(ncomp == 3);
    REQUIRE(bf.size() == static_cast<size_t>(uv.rows() * n * 3));
    Eigen::MatrixXd dU, dV;
    triangle_basis_gradients(p, uv, dU, dV);
    double gerr = 0, scale = 1;
    for (int i = 0; i < uv.rows(); ++i)
      for (int k = 0; k < n; ++k) {
        gerr = std::max(gerr, std::abs(dU(i, k) - bf[(i * n + k) * 3 + 0]));
        gerr = std::max(gerr, std::abs(dV(i, k) - bf[(i * n + k) * 3 + 1]));
        scale = std::max(scale, std::abs(dU(i, k)));
      }
    CHECK(gerr < 1e-9 * scale);
  }
}

TEST_CASE("partition of unity, Kronecker delta, gradients by finite differences") {
  for (int p = 1; p <= 10; ++p) {
    CAPTURE(p);
    const Eigen::MatrixXd uv = sample_points(30, 100 + p);
    const Eigen::MatrixXd B = triangle_basis(p, uv);
    CHECK((B.rowwise().sum().array() - 1).abs().maxCoeff() < 1e-12);
    const Eigen::MatrixXd X = triangle_reference_nodes(p);
    const Eigen::MatrixXd D = triangle_basis(p, X);
    CHECK((D - Eigen::MatrixXd::Identity(X.rows(), X.rows())).cwiseAbs().maxCoeff() < 1e-13);
    Eigen::MatrixXd dU, dV;
    triangle_basis_gradients(p, uv, dU, dV);
    CHECK(dU.rowwise().sum().cwiseAbs().maxCoeff() < 1e-10);
    CHECK(dV.rowwise().sum().cwiseAbs().maxCoeff() < 1e-10);
    const double h = 1e-6;
    Eigen::MatrixXd up = uv, um = uv, vp = uv, vm = uv;
    up.col(0).array() += h, um.col(0).array() -= h, vp.col(1).array() += h, vm.col(1).array() -= h;
    const Eigen::MatrixXd fdU = (triangle_basis(p, up) - triangle_basis(p, um)) / (2 * h);
    const Eigen::MatrixXd fdV = (triangle_basis(p, vp) - triangle_basis(p, vm)) / (2 * h);
    const double scale = std::max(1.0, dU.cwiseAbs().maxCoeff());
    CHECK((fdU - dU).cwiseAbs().maxCoeff() < 1e-5 * scale);
    CHECK((fdV - dV).cwiseAbs().maxCoeff() < 1e-5 * scale);
  }
}

TEST_CASE("evaluate_triangle reproduces polynomials of degree p") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int p = 1; p <= 6; ++p) {
    CAPTURE(p);
    // Random polynomial map of total degree p, sampled at the nodes, is reproduced exactly.
    Eigen::MatrixXd coef(triangle_node_count(p), 3);
    for (int i = 0; i < coef.rows(); ++i)
      for (int d = 0; d < 3; ++d) coef(i, d) = U(rng);
    auto poly = [&](const Eigen::MatrixXd& uv) {
      Eigen::MatrixXd out = Eigen::MatrixXd::Zero(uv.rows(), 3);
      for (int r = 0; r < uv.rows(); ++r) {
        int t = 0;
        for (int a = 0; a <= p; ++a)
          for (int b = 0; a + b <= p; ++b, ++t)
            out.row(r) += coef.row(t) * std::pow(uv(r, 0), a) * std::pow(uv(r, 1), b);
      }
      return out;
    };
    const Eigen::MatrixXd nodes = poly(triangle_reference_nodes(p));
    const Eigen::MatrixXd uv = sample_points(25, 11);
    CHECK((evaluate_triangle(nodes, p, uv) - poly(uv)).cwiseAbs().maxCoeff() < 1e-12);
    Eigen::MatrixXd Xu, Xv;
    evaluate_triangle_tangents(nodes, p, uv, Xu, Xv);
    CHECK(Xu.rows() == uv.rows());
  }
  CHECK_THROWS_AS(evaluate_triangle(Eigen::MatrixXd::Zero(5, 3), 2, Eigen::MatrixXd::Zero(1, 2)), UsageError);
  CHECK_THROWS_AS(triangle_basis(0, Eigen::MatrixXd::Zero(1, 2)), UsageError);
}
