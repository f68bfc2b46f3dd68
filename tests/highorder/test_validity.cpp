// Validity of curved triangles: Bernstein algebra, exact Jacobian cases, bounds against dense
// sampling (J evaluated independently with the Lagrange gradients), subdivision, repair.
#include "engine/highorder/validity.hpp"

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/highorder/bezier.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <doctest/doctest.h>
#include <gmsh.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>
#include <random>
#include <vector>

using namespace hocurve;

namespace {

// Uniform random points in the reference triangle.
Eigen::MatrixXd random_uv(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  Eigen::MatrixXd uv(n, 2);
  for (int i = 0; i < n; ++i) {
    double u = U(rng), v = U(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    uv.row(i) << u, v;
  }
  return uv;
}

// Dense lattice of degree m (all (i/m, j/m), i + j <= m).
Eigen::MatrixXd dense_uv(int m) {
  Eigen::MatrixXd uv((m + 1) * (m + 2) / 2, 2);
  int r = 0;
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i + j <= m; ++i) uv.row(r++) << double(i) / m, double(j) / m;
  return uv;
}

// J / J_straight evaluated directly in 3D from the Lagrange gradients (independent of the
// Bernstein code): n . (x_u x x_v) / |(x1 - x0) x (x2 - x0)|.
Eigen::VectorXd scaled_jacobian_samples(const Eigen::MatrixXd& X, int p, const Eigen::MatrixXd& uv) {
  Eigen::MatrixXd dU, dV;
  triangle_basis_gradients(p, uv, dU, dV);
  const Eigen::MatrixXd Xu = dU * X, Xv = dV * X;
  const Eigen::Vector3d a = X.row(0), b = X.row(1), c = X.row(2);
  const Eigen::Vector3d cr = (b - a).cross(c - a);
  const double js = cr.norm();
  const Eigen::Vector3d n = cr / js;
  Eigen::VectorXd J(uv.rows());
  for (Eigen::Index i = 0; i < uv.rows(); ++i)
    J[i] = n.dot(Eigen::Vector3d(Xu.row(i)).cross(Eigen::Vector3d(Xv.row(i)))) / js;
  return J;
}

// A straight order-p triangle with corners a, b, c and equispaced nodes (Gmsh order).
Eigen::MatrixXd straight_element(int p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                 NodeDistribution d = NodeDistribution::Equispaced) {
  const Eigen::MatrixXd uv = triangle_reference_nodes(p, d);
  Eigen::MatrixXd X(uv.rows(), 3);
  for (Eigen::Index k = 0; k < uv.rows(); ++k) X.row(k) = (a + uv(k, 0) * (b - a) + uv(k, 1) * (c - a)).transpose();
  return X;
}

Eigen::Vector3d random_vec(std::mt19937& rng, double s = 1) {
  std::uniform_real_distribution<double> U(-s, s);
  return {U(rng), U(rng), U(rng)};
}

// Random straight triangle with edges ~1 and perturbed non-corner nodes (3D displacement of
// size amp relative to the node spacing 1/p).
Eigen::MatrixXd random_perturbed_element(int p, double amp, std::mt19937& rng) {
  Eigen::Vector3d a = random_vec(rng), b = a + Eigen::Vector3d(1, 0, 0) + random_vec(rng, 0.3),
                  c = a + Eigen::Vector3d(0.3, 1, 0) + random_vec(rng, 0.3);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.3, random_vec(rng).normalized()).toRotationMatrix();
  a = R * a, b = R * b, c = R * c;
  Eigen::MatrixXd X = straight_element(p, a, b, c);
  std::uniform_real_distribution<double> U(-amp / p, amp / p);
  for (Eigen::Index k = 3; k < X.rows(); ++k)
    for (int j = 0; j < 3; ++j) X(k, j) += U(rng);
  return X;
}

// Icosphere: icosahedron subdivided `levels` times, vertices on the unit sphere.
Mesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Eigen::Vector3d> V = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& v : V) v.normalize();
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int i, int j) {
      const auto key = std::minmax(i, j);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back((V[i] + V[j]).normalized());
      mid[key] = static_cast<int>(V.size()) - 1;
      return static_cast<int>(V.size()) - 1;
    };
    std::vector<std::array<int, 3>> G;
    for (const auto& f : F) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      G.push_back({f[0], a, c});
      G.push_back({f[1], b, a});
      G.push_back({f[2], c, b});
      G.push_back({a, b, c});
    }
    F.swap(G);
  }
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(static_cast<Eigen::Index>(i)) << F[i][0], F[i][1], F[i][2];
  return m;
}

// Curved high-order sphere: straight nodes projected radially onto the unit sphere.
HighOrderMesh curved_sphere(int levels, int p, NodeDistribution d) {
  const Mesh m = icosphere(levels);
  const Topology T = build_topology(m.F, m.num_vertices());
  HighOrderMesh hm = make_straight_high_order(m, T, p, d);
  hm.edge_nodes.rowwise().normalize();
  if (hm.face_nodes.rows()) hm.face_nodes.rowwise().normalize();
  return hm;
}

}  // namespace

TEST_CASE("Bernstein algebra: partition of unity, Lagrange conversion, products, subdivision") {
  std::mt19937 rng(7);
  const Eigen::MatrixXd uv = random_uv(40, rng);
  for (int d = 0; d <= 10; ++d) {
    const Eigen::MatrixXd T = bernstein_matrix(d, uv);
    CHECK((T.rowwise().sum().array() - 1).abs().maxCoeff() < 1e-13);
    CHECK(T.minCoeff() >= 0);
  }
  // Lagrange -> Bernstein reproduces the Lagrange interpolant (Gmsh order) everywhere.
  for (int p = 1; p <= 6; ++p) {
    const Eigen::MatrixXd M = lagrange_to_bernstein(p);
    const Eigen::MatrixXd X = Eigen::MatrixXd::Random(triangle_node_count(p), 3);
    const Eigen::MatrixXd lag = triangle_basis(p, uv) * X;
    const Eigen::MatrixXd bez = bernstein_matrix(p, uv) * (M * X);
    CHECK((lag - bez).cwiseAbs().maxCoeff() < 1e-11);
    // Derivative nets: against the Lagrange gradients.
    Eigen::MatrixXd Pu, Pv, dU, dV;
    bernstein_derivatives(p, M * X, Pu, Pv);
    triangle_basis_gradients(p, uv, dU, dV);
    CHECK((bernstein_matrix(p - 1, uv) * Pu - dU * X).cwiseAbs().maxCoeff() < 1e-10);
    CHECK((bernstein_matrix(p - 1, uv) * Pv - dV * X).cwiseAbs().maxCoeff() < 1e-10);
  }
  // Products: pointwise product of the evaluations.
  for (int a = 0; a <= 5; ++a)
    for (int b = 0; b <= 5; ++b) {
      const BernsteinProduct prod = make_bernstein_product(a, b);
      const Eigen::VectorXd f = Eigen::VectorXd::Random(bernstein_count(a)), h = Eigen::VectorXd::Random(bernstein_count(b));
      const Eigen::VectorXd c = bernstein_multiply(prod, f, h);
      const Eigen::VectorXd lhs = bernstein_matrix(a + b, uv) * c;
      const Eigen::VectorXd rhs = (bernstein_matrix(a, uv) * f).cwiseProduct(bernstein_matrix(b, uv) * h);
      CHECK((lhs - rhs).cwiseAbs().maxCoeff() < 1e-12);
    }
  // Subdivision: child polynomial at (s, t) equals the parent at the mapped point.
  for (int d : {1, 2, 5, 10}) {
    const Eigen::VectorXd f = Eigen::VectorXd::Random(bernstein_count(d));
    for (int c = 0; c < 4; ++c) {
      const Eigen::Matrix<double, 3, 2> Q = subdivision_child_corners(c);
      Eigen::MatrixXd mapped(uv.rows(), 2);
      for (Eigen::Index i = 0; i < uv.rows(); ++i)
        mapped.row(i) = (1 - uv(i, 0) - uv(i, 1)) * Q.row(0) + uv(i, 0) * Q.row(1) + uv(i, 1) * Q.row(2);
      const Eigen::MatrixXd S = bernstein_subdivision_matrix(d, c);
      CHECK((bernstein_matrix(d, uv) * (S * f) - bernstein_matrix(d, mapped) * f).cwiseAbs().maxCoeff() < 1e-12);
      // Convex combinations: rows are non-negative and sum to one.
      CHECK(S.minCoeff() >= 0);
      CHECK((S.rowwise().sum().array() - 1).abs().maxCoeff() < 1e-14);
    }
  }
}

TEST_CASE("straight elements are valid with scaled Jacobian 1") {
  std::mt19937 rng(11);
  for (int p = 1; p <= 6; ++p) {
    const JacobianBasis B(p);
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Vector3d a = random_vec(rng), b = random_vec(rng), c = random_vec(rng);
      const Eigen::MatrixXd X = straight_element(p, a, b, c);
      const ElementValidity ev = check_element(B, X);
      CHECK(ev.valid);
      CHECK_FALSE(ev.degenerate);
      CHECK(ev.min_scaled_jacobian == doctest::Approx(1).epsilon(1e-9));
      CHECK(ev.max_scaled_jacobian == doctest::Approx(1).epsilon(1e-9));
      // Reversed orientation is measured against its own straight normal: still valid.
      Eigen::MatrixXd Y = straight_element(p, a, c, b);
      CHECK(check_element(B, Y).valid);
    }
    // Lobatto-placed nodes on a straight triangle, read as equispaced Lagrange nodes, are a
    // reparametrisation phi(u) x phi(v) near corner 0: J / J_straight there is phi'(0)^2, with
    // phi the equispaced interpolant of the 1D Lobatto points (derivative weights of the
    // equispaced Lagrange basis at 0 computed here from their product form).
    const Eigen::MatrixXd XL = straight_element(p, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 0, 1),
                                                Eigen::Vector3d(0, 1, 0), NodeDistribution::Lobatto);
    const ElementValidity evl = check_element(B, XL);
    CHECK(evl.valid);
    const Eigen::VectorXd t = line_reference_nodes(p, NodeDistribution::Lobatto);
    double dphi = 0;
    for (int k = 1; k <= p; ++k) {
      // l_k'(0) for nodes s_i = i/p: prod_{i != k, i != 0} (0 - s_i) / (s_k - s_i) / (s_k - s_0).
      double w = 1.0 / (double(k) / p);
      for (int i = 1; i <= p; ++i)
        if (i != k) w *= (0 - double(i) / p) / (double(k) / p - double(i) / p);
      dphi += t[k] * w;
    }
    const Eigen::VectorXd bl = jacobian_bezier(B, XL);
    CHECK(bl[bernstein_index(B.d, 0, 0)] == doctest::Approx(dphi * dphi).epsilon(1e-9));
    CHECK(evl.min_scaled_jacobian <= dphi * dphi + 1e-12);
  }
}

TEST_CASE("P2: one mid-edge node displaced by delta has min J/J_straight = 1 - 4 delta exactly") {
  // Corners (0,0),(1,0),(0,1); node of edge 0 moved to (1/2, delta): y = v + 4 delta u (1-u-v),
  // so J = 1 - 4 delta u, minimum 1 - 4 delta at corner 1. Embedded in 3D by a rotation.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d o(0.3, -2, 5);
  const JacobianBasis B(2);
  for (double delta : {-0.5, 0.1, 0.2, 0.24, 0.25, 0.3, 1.5}) {
    Eigen::MatrixXd X = straight_element(2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
    X(3, 1) = delta;  // Gmsh P2: nodes 3, 4, 5 on edges 0-1, 1-2, 2-0
    for (Eigen::Index k = 0; k < X.rows(); ++k) X.row(k) = (R * X.row(k).transpose() * 3.0 + o).transpose();
    const ElementValidity ev = check_element(B, X);
    CHECK(ev.min_scaled_jacobian == doctest::Approx(1 - 4 * std::max(delta, 0.0)).epsilon(1e-10));
    CHECK(ev.max_scaled_jacobian == doctest::Approx(1 - 4 * std::min(delta, 0.0)).epsilon(1e-10));
    CHECK(ev.valid == (delta < 0.25));
  }
  // Pulled across the opposite side (beyond corner 2 at (0,1)): invalid.
  Eigen::MatrixXd X = straight_element(2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
  X.row(3) << 0.2, 1.6, 0.1;
  CHECK_FALSE(check_element(X, 2).valid);
  // Out-of-plane displacement alone does not change J (n is the straight normal).
  X = straight_element(2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
  X(4, 2) = 0.4;
  CHECK(check_element(X, 2).min_scaled_jacobian == doctest::Approx(1));
  // A fold against the straight normal: the face node pushed past an edge in P3.
  Eigen::MatrixXd Y = straight_element(3, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
  Y.row(9) << 0.33, -0.5, 0;  // the single interior node of P3
  CHECK_FALSE(check_element(Y, 3).valid);
}

TEST_CASE("degenerate straight triangles are reported, never valid") {
  Eigen::MatrixXd X = straight_element(3, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(2, 2, 2));
  const ElementValidity ev = check_element(X, 3);
  CHECK(ev.degenerate);
  CHECK_FALSE(ev.valid);
  CHECK(jacobian_bezier(JacobianBasis(3), X).size() == 0);
  CHECK_THROWS_AS(check_element(Eigen::MatrixXd::Zero(5, 3), 2), UsageError);
  ValidityOptions bad;
  bad.shrink = 1.5;
  CHECK_THROWS_AS(check_element(X, 3, bad), UsageError);
}

TEST_CASE("routes A and B give the same Bernstein coefficients") {
  std::mt19937 rng(3);
  for (int p = 1; p <= 6; ++p) {
    const JacobianBasis B(p);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::MatrixXd X = random_perturbed_element(p, 0.15, rng);
      const Eigen::VectorXd bB = jacobian_bezier(B, X), bA = jacobian_bezier_sampled(B, X);
      REQUIRE(bB.size() == B.num_coefficients);
      CHECK((bA - bB).cwiseAbs().maxCoeff() < 1e-9 * std::max(1.0, bB.cwiseAbs().maxCoeff()));
      // Corner coefficients are J at the corners.
      const Eigen::MatrixXd corners = (Eigen::MatrixXd(3, 2) << 0, 0, 1, 0, 0, 1).finished();
      const Eigen::VectorXd Jc = scaled_jacobian_samples(X, p, corners);
      const int d = B.d;
      CHECK(bB[bernstein_index(d, 0, 0)] == doctest::Approx(Jc[0]).epsilon(1e-9));
      CHECK(bB[bernstein_index(d, d, 0)] == doctest::Approx(Jc[1]).epsilon(1e-9));
      CHECK(bB[bernstein_index(d, 0, d)] == doctest::Approx(Jc[2]).epsilon(1e-9));
    }
  }
}

TEST_CASE("bounds against dense sampling, 200 random elements per order") {
  std::mt19937 rng(2024);
  const Eigen::MatrixXd uv = dense_uv(36);
  for (int p = 2; p <= 6; ++p) {
    const JacobianBasis B(p);
    int n_valid = 0, n_invalid_sampled = 0, n_subdivided = 0, n_undecided = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const double amp = (0.1 + 0.5 * (trial % 10) / 9.0) * 2.0 / p;  // from gentle to folding
      const Eigen::MatrixXd X = random_perturbed_element(p, amp, rng);
      const Eigen::VectorXd J = scaled_jacobian_samples(X, p, uv);
      const Eigen::VectorXd b = jacobian_bezier(B, X);
      const double tol = 1e-10 * std::max(1.0, b.cwiseAbs().maxCoeff());
      CHECK(b.minCoeff() <= J.minCoeff() + tol);
      CHECK(b.maxCoeff() >= J.maxCoeff() - tol);
      const ElementValidity ev = check_element(B, X);
      if (J.minCoeff() <= 0) {
        ++n_invalid_sampled;
        CHECK_FALSE(ev.valid);
      }
      if (ev.valid) {
        ++n_valid;
        CHECK(ev.min_scaled_jacobian <= J.minCoeff() + tol);
        CHECK(ev.max_scaled_jacobian >= J.maxCoeff() - tol);
        CHECK(ev.min_scaled_jacobian > 0);
      }
      if (ev.subdivisions > 0) ++n_subdivided;
      if (!ev.valid && J.minCoeff() > 0) ++n_undecided;  // a near-zero minimum the samples missed, or the cap
    }
    MESSAGE("p = " << p << ": valid " << n_valid << ", sampled-invalid " << n_invalid_sampled << ", subdivided "
                    << n_subdivided << ", invalid with dense samples > 0: " << n_undecided);
    // The sample covers both verdicts.
    CHECK(n_valid > 20);
    CHECK(n_invalid_sampled > 5);
  }
}

TEST_CASE("P6: negative Bezier minimum, valid after subdivision, bounds converge") {
  std::mt19937 rng(99);
  const JacobianBasis B(6);
  const Eigen::MatrixXd uv = dense_uv(60);
  int found = 0;
  for (int trial = 0; trial < 4000 && found < 3; ++trial) {
    const Eigen::MatrixXd X = random_perturbed_element(6, 0.3, rng);
    const Eigen::VectorXd b = jacobian_bezier(B, X);
    if (b.minCoeff() >= 0) continue;
    const ElementValidity ev = check_element(B, X);
    if (!ev.valid) continue;
    ++found;
    const double sampled = scaled_jacobian_samples(X, 6, uv).minCoeff();
    CHECK(sampled > 0);
    CHECK(ev.subdivisions >= 1);
    CHECK(ev.min_scaled_jacobian > 0);
    CHECK(ev.min_scaled_jacobian <= sampled + 1e-10);
    double prev = -1e300;
    std::vector<double> gap;
    for (int depth = 0; depth <= 4; ++depth) {
      const double lb = bezier_lower_bound(B, b, depth);
      CHECK(lb >= prev - 1e-12);  // subdivision never loosens the bound
      CHECK(lb <= sampled + 1e-10);
      gap.push_back(sampled - lb);
      prev = lb;
    }
    // Quadratic convergence: each level divides the gap by ~4; ask for 3 levels >= 10x.
    CHECK(gap[3] < 0.1 * gap[0]);
  }
  CHECK(found >= 1);
}

TEST_CASE("repair: a wildly perturbed sphere ends valid, far elements untouched") {
  for (NodeDistribution dist : {NodeDistribution::Equispaced, NodeDistribution::Lobatto}) {
    const int p = 4;
    HighOrderMesh hm = curved_sphere(2, p, dist);  // 320 faces
    const ValidityReport clean = check_validity(hm);
    INFO("distribution " << std::string(to_string(dist)) << ": min scaled J " << clean.min_scaled_jacobian);
    REQUIRE(clean.invalid_after == 0);
    CHECK(clean.degenerate_input == 0);
    // Lobatto-placed nodes read as equispaced Lagrange nodes (what Gmsh does) distort the
    // parametrisation near the corners (see the straight-element test), so only ask for > 0.
    CHECK(clean.min_scaled_jacobian > (dist == NodeDistribution::Equispaced ? 0.5 : 0.0));
    const HighOrderMesh original = hm;

    // Perturb every high-order node of a few faces wildly.
    std::mt19937 rng(5);
    const std::vector<int> bad_faces = {0, 57, 140, 141, 299};
    const int nv = static_cast<int>(hm.V.rows()), ned = static_cast<int>(hm.edge_nodes.rows());
    const int n = triangle_node_count(p);
    std::vector<int> idx(n);
    for (int f : bad_faces) {
      element_node_indices(hm, f, idx.data());
      for (int k = 3; k < n; ++k) {
        const int g = idx[k];
        const Eigen::RowVector3d dx = random_vec(rng, 0.6).transpose();
        if (g < nv + ned) hm.edge_nodes.row(g - nv) += dx;
        else hm.face_nodes.row(g - nv - ned) += dx;
      }
    }
    const ValidityReport before = check_validity(hm);
    CHECK(before.invalid_after >= 3);

    HighOrderMesh again = hm;
    const ValidityReport rep = repair_validity(hm);
    const ValidityReport rep2 = repair_validity(again);
    CHECK(rep2.repaired == rep.repaired);  // deterministic: same counts and same nodes
    CHECK(again.edge_nodes == hm.edge_nodes);
    CHECK(again.face_nodes == hm.face_nodes);
    CHECK(rep.invalid_before == before.invalid_after);
    CHECK(rep.invalid_after == 0);
    CHECK(rep.invalid_faces.empty());
    CHECK(rep.repaired >= rep.invalid_before);
    CHECK(rep.min_scaled_jacobian > 0);
    const ValidityReport after = check_validity(hm);
    CHECK(after.invalid_after == 0);
    CHECK(after.min_scaled_jacobian == doctest::Approx(rep.min_scaled_jacobian));

    // Faces away from the perturbed ones (centroid farther than 0.6 on the unit sphere, about
    // 3 rings at this resolution) keep their nodes bit for bit.
    auto centroid = [&](int f) {
      return Eigen::Vector3d((hm.V.row(hm.F(f, 0)) + hm.V.row(hm.F(f, 1)) + hm.V.row(hm.F(f, 2))) / 3);
    };
    int far = 0;
    for (int f = 0; f < hm.num_faces(); ++f) {
      double dmin = 1e9;
      for (int g : bad_faces) dmin = std::min(dmin, (centroid(f) - centroid(g)).norm());
      if (dmin < 0.6) continue;
      ++far;
      CHECK(element_nodes(hm, f) == element_nodes(original, f));
    }
    CHECK(far > 150);
  }
}

TEST_CASE("repair: the quality floor takes off only what it needs (bisection), invalid elements fixed steps") {
  // One P2 triangle (0,0),(1,0),(0,1) with its edge-0 node at (1/2, delta): min J = 1 - 4 delta
  // (test above). Scaled by s, the displacement clears the floor 0.01 for 4 delta s <= 0.99.
  Mesh m;
  m.V = (Eigen::MatrixXd(3, 3) << 0, 0, 0, 1, 0, 0, 0, 1, 0).finished();
  m.F = (Eigen::MatrixXi(1, 3) << 0, 1, 2).finished();
  const Topology T = build_topology(m.F, 3);
  for (double delta : {0.249, 0.3})
    for (bool bisect : {true, false}) {
      HighOrderMesh hm = make_straight_high_order(m, T, 2);
      int e01 = -1;
      for (int e = 0; e < 3; ++e)
        if (std::min(hm.E(e, 0), hm.E(e, 1)) == 0 && std::max(hm.E(e, 0), hm.E(e, 1)) == 1) e01 = e;
      REQUIRE(e01 >= 0);
      hm.edge_nodes(e01, 1) = delta;
      ValidityOptions opt;
      opt.bisect = bisect;
      const ValidityReport rep = repair_validity(hm, opt);
      CHECK(rep.invalid_before == (delta > 0.25 ? 1 : 0));
      CHECK(rep.invalid_after == 0);
      CHECK(hm.edge_nodes(e01, 0) == doctest::Approx(0.5));
      if (delta > 0.25 || !bisect) {  // one step of 0.8: J = 1 - 3.2 delta, above the floor
        CHECK(hm.edge_nodes(e01, 1) == doctest::Approx(0.8 * delta).epsilon(1e-12));
      } else {  // 0.2475, to the bisection's 2^-12 of delta
        CHECK(hm.edge_nodes(e01, 1) <= 0.2475 + 1e-12);
        CHECK(hm.edge_nodes(e01, 1) >= 0.2475 - delta / 4096 - 1e-12);
      }
    }
}

TEST_CASE("repair with zero shrink steps goes straight exactly like make_straight_high_order") {
  for (NodeDistribution dist : {NodeDistribution::Equispaced, NodeDistribution::Lobatto}) {
    const int p = 5;
    const Mesh m = icosphere(1);
    const Topology T = build_topology(m.F, m.num_vertices());
    const HighOrderMesh straight = make_straight_high_order(m, T, p, dist);
    HighOrderMesh hm = straight;
    std::mt19937 rng(1);
    for (Eigen::Index r = 0; r < hm.edge_nodes.rows(); ++r) hm.edge_nodes.row(r) += random_vec(rng, 0.5).transpose();
    for (Eigen::Index r = 0; r < hm.face_nodes.rows(); ++r) hm.face_nodes.row(r) += random_vec(rng, 0.5).transpose();
    // A non-finite node makes its faces invalid, and repair still ends straight and finite.
    hm.edge_nodes(7, 1) = std::numeric_limits<double>::quiet_NaN();
    for (int f = 0; f < hm.num_faces(); ++f)
      for (int j = 0; j < 3; ++j)
        if (hm.FE(f, j) == 7 / (p - 1)) CHECK_FALSE(check_element(element_nodes(hm, f), p).valid);
    ValidityOptions opt;
    opt.max_shrink_steps = 0;
    const ValidityReport rep = repair_validity(hm, opt);
    CHECK(rep.invalid_before > 0);
    CHECK(rep.invalid_after == 0);
    CHECK(hm.edge_nodes.allFinite());
    const std::vector<ElementValidity> ev = check_elements(hm);
    for (int f = 0; f < hm.num_faces(); ++f) {
      // Every face is either untouched-and-valid or exactly straight.
      CHECK(ev[f].valid);
      const bool is_straight = element_nodes(hm, f) == element_nodes(straight, f);
      if (dist == NodeDistribution::Equispaced && is_straight)
        CHECK(ev[f].min_scaled_jacobian == doctest::Approx(1).epsilon(1e-9));
    }
  }
}

TEST_CASE("check_validity is deterministic and counts degenerate inputs, speed at P4") {
  const HighOrderMesh hm = curved_sphere(5, 4, NodeDistribution::Equispaced);  // 20480 faces
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  int reps = 0;
  ValidityReport r1;
  do {
    r1 = check_validity(hm);
    ++reps;
  } while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 1.0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;  // all threads of the process
  MESSAGE("P4 validity check: " << (reps * double(hm.num_faces()) / secs / 1e6) << " M elements/s wall, "
                                << (reps * double(hm.num_faces()) / cpu / 1e6) << " M elements per CPU second");
  const ValidityReport r2 = check_validity(hm);
  CHECK(r1.invalid_after == 0);
  CHECK(r1.min_scaled_jacobian == r2.min_scaled_jacobian);

  // Degenerate input: three collinear corners.
  Mesh m;
  m.V = (Eigen::MatrixXd(4, 3) << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0).finished();
  m.F = (Eigen::MatrixXi(2, 3) << 0, 1, 2, 0, 1, 3).finished();
  const Topology T = build_topology(m.F, 4);
  const HighOrderMesh dh = make_straight_high_order(m, T, 3);
  const ValidityReport rd = check_validity(dh);
  CHECK(rd.degenerate_input == 1);
  CHECK(rd.invalid_after == 1);
  CHECK(rd.invalid_faces == std::vector<int>{0});
  CHECK(rd.min_scaled_jacobian == doctest::Approx(1));

  // Inconsistent meshes are refused with an InputError, not a crash.
  HighOrderMesh broken = dh;
  broken.FE(1, 2) = 99;
  CHECK_THROWS_AS(check_validity(broken), InputError);
  broken = dh;
  broken.face_nodes.conservativeResize(1, 3);
  CHECK_THROWS_AS(repair_validity(broken), InputError);
}

TEST_CASE("verdicts agree with Gmsh's AnalyseMeshQuality (minJ/maxJ) on random elements") {
  gmsh::initialize();
  gmsh::option::setNumber("General.Terminal", 0);
  std::mt19937 rng(77);
  for (int p = 2; p <= 5; ++p) {
    gmsh::model::add("validity_p" + std::to_string(p));
    const int tag = gmsh::model::addDiscreteEntity(2);
    const int n = triangle_node_count(p), count = 150;
    std::vector<std::size_t> node_tags, elem_nodes, elem_tags;
    std::vector<double> coords;
    std::vector<ElementValidity> ours;
    const JacobianBasis B(p);
    for (int e = 0; e < count; ++e) {
      const double amp = (0.1 + 0.5 * (e % 10) / 9.0) * 2.0 / p;
      const Eigen::MatrixXd X = random_perturbed_element(p, amp, rng);
      ours.push_back(check_element(B, X));
      for (int k = 0; k < n; ++k) {
        node_tags.push_back(node_tags.size() + 1);
        elem_nodes.push_back(node_tags.back());
        for (int c = 0; c < 3; ++c) coords.push_back(X(k, c));
      }
      elem_tags.push_back(e + 1);
    }
    gmsh::model::mesh::addNodes(2, tag, node_tags, coords);
    gmsh::model::mesh::addElementsByType(tag, gmsh_triangle_type(p), elem_tags, elem_nodes);
    gmsh::plugin::setNumber("AnalyseMeshQuality", "JacobianDeterminant", 1);
    gmsh::plugin::setNumber("AnalyseMeshQuality", "CreateView", 1);
    gmsh::plugin::setNumber("AnalyseMeshQuality", "DimensionOfElements", 2);
    gmsh::plugin::setNumber("AnalyseMeshQuality", "Recompute", 1);
    gmsh::plugin::run("AnalyseMeshQuality");
    std::vector<int> views;
    gmsh::view::getTags(views);
    REQUIRE(!views.empty());
    std::string type;
    std::vector<std::size_t> tags;
    std::vector<std::vector<double>> data;
    double time;
    int ncomp;
    gmsh::view::getModelData(views.back(), 0, type, tags, data, time, ncomp);
    REQUIRE(tags.size() == static_cast<size_t>(count));
    int agree = 0, compared = 0;
    for (size_t i = 0; i < tags.size(); ++i) {
      const double ratio = data[i][0];  // Gmsh's bounded min J / max J
      if (std::abs(ratio) < 1e-2) continue;  // too close to zero for either tolerance
      const ElementValidity& ev = ours[tags[i] - 1];
      ++compared;
      if (ev.valid == (ratio > 0)) ++agree;
      INFO("p " << p << " element " << tags[i] << " gmsh " << ratio << " ours " << ev.min_scaled_jacobian << " / "
                << ev.max_scaled_jacobian);
      CHECK(ev.valid == (ratio > 0));
      // Our certified bounds bracket Gmsh's ratio: lo/hi <= minJ/maxJ (hi >= maxJ > 0).
      if (ev.valid) CHECK(ev.min_scaled_jacobian / ev.max_scaled_jacobian <= ratio + 1e-3);
    }
    MESSAGE("p = " << p << ": verdicts agree with Gmsh on " << agree << " / " << compared << " elements");
    for (int v : views) gmsh::view::remove(v);
    gmsh::model::remove();
  }
  gmsh::finalize();
}
