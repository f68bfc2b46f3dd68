// The tet bases and the certified Jacobian bound on elements with known answers.
#include <doctest/doctest.h>

#include "engine/highorder/reference_nodes.hpp"
#include "engine/volume/tet_basis.hpp"
#include "engine/volume/tet_jacobian.hpp"

#include <Eigen/Geometry>
#include <cstdlib>

using namespace hocurve;

TEST_CASE("tet Lagrange basis: Kronecker delta at Gmsh's nodes, gradients sum to 0") {
  for (int p = 1; p <= 4; ++p) {
    const Eigen::MatrixXd nodes = tet_lattice(p).cast<double>() / p;
    CHECK((tet_basis(p, nodes) - Eigen::MatrixXd::Identity(nodes.rows(), nodes.rows())).norm() < 1e-12);
    Eigen::MatrixXd du, dv, dw;
    tet_basis_gradients(p, tet_bernstein_lattice(3), du, dv, dw);
    CHECK(du.rowwise().sum().norm() < 1e-11);
    // The gradients reproduce the linear function u exactly.
    CHECK((du * nodes.col(0) - Eigen::VectorXd::Ones(du.rows())).norm() < 1e-11);
    CHECK((dv * nodes.col(0)).norm() < 1e-11);
  }
}

TEST_CASE("tet Jacobian bound: straight tets, a bulge that folds and one that does not") {
  for (int p = 1; p <= 4; ++p) {
    CAPTURE(p);
    const TetJacobianBasis b(p);
    Eigen::MatrixXd X = tet_lattice(p).cast<double>() / p;
    X.col(0) *= 2;  // a straight tet of det J = 2
    TetQuality q = check_tet(b, X);
    CHECK(q.valid);
    CHECK(q.min_ratio == doctest::Approx(1));
    CHECK(q.scaled_jacobian == doctest::Approx(1));
    if (p < 2) continue;
    // Push the node nearest the middle of edge 0-1 toward the opposite edge (2-3) and beyond.
    const int k = 4;  // first node of edge 0->1 in Gmsh order
    for (const double push : {0.2, 1.5}) {  // x the node spacing 1/p
      Eigen::MatrixXd Y = X;
      Y.row(k) += push / p * Eigen::RowVector3d(0, 1, 1);
      q = check_tet(b, Y);
      CHECK(q.valid == (push < 1));
      CHECK(q.scaled_jacobian < 1);
    }
  }
}

TEST_CASE("tet Jacobian bound: certified tets are valid at dense samples, subdivision decides more") {
  // Random perturbations of every node: whatever the verdict, a certified tet has det J > 0 at
  // 2000 random points, subdividing only tightens the bound, and some tets need it.
  std::srand(7);
  for (int p = 2; p <= 3; ++p) {
    CAPTURE(p);
    const TetJacobianBasis b(p);
    const Eigen::MatrixXd X = tet_lattice(p).cast<double>() / p;
    Eigen::MatrixXd pts = (Eigen::MatrixXd::Random(4000, 3).array() + 1) / 2;
    std::vector<int> inside;
    for (int i = 0; i < pts.rows(); ++i)
      if (pts.row(i).sum() <= 1) inside.push_back(i);
    pts = pts(inside, Eigen::all).eval();
    Eigen::MatrixXd du, dv, dw;
    tet_basis_gradients(p, pts, du, dv, dw);
    int by_subdivision = 0, certified = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const Eigen::MatrixXd Y = X + (0.35 / p) * Eigen::MatrixXd::Random(X.rows(), 3);
      const TetQuality q0 = check_tet(b, Y, {0}), q3 = check_tet(b, Y, {3});
      CHECK(q3.min_ratio >= q0.min_ratio - 1e-12);
      if (!q3.valid) continue;
      ++certified;
      by_subdivision += !q0.valid;
      const Eigen::MatrixXd Xu = du * Y, Xv = dv * Y, Xw = dw * Y;
      double lo = 1e300;
      for (Eigen::Index s = 0; s < pts.rows(); ++s) {
        const Eigen::RowVector3d u = Xu.row(s), v = Xv.row(s), w = Xw.row(s);
        lo = std::min(lo, u.dot(v.cross(w)));
      }
      CHECK(lo >= q3.min_ratio * std::abs(straight_jacobian(Y)) - 1e-12);
    }
    MESSAGE("P" << p << ": " << certified << " of 300 certified, " << by_subdivision << " by subdivision");
    CHECK(certified >= 10);
    CHECK(by_subdivision > 0);
  }
}
