// Unit tests of the SOLF building blocks: height-function fits reproduce polynomials, degree
// reduction, wedges and stencils that respect features, curve fits along a rim.
#include <doctest/doctest.h>

#include "engine/core/topology.hpp"
#include "engine/curving/curve_fit.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/curving/test_meshes.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

using namespace hocurve;

namespace {
/// A polynomial height of total degree d (no constant term) in a frame (o; t1, t2, n).
double poly(double u, double v, int d) {
  double s = 0.3 * u - 0.2 * v;
  if (d >= 2) s += 0.7 * u * u - 0.4 * u * v + 0.25 * v * v;
  if (d >= 3) s += 0.5 * u * u * u - 0.3 * u * v * v;
  if (d >= 4) s += 0.2 * u * u * u * u + 0.1 * u * u * v * v - 0.15 * v * v * v * v;
  return s;
}
}  // namespace

TEST_CASE("height fits reproduce polynomials of their degree in any frame") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int p = 1; p <= 6; ++p) {
    const int d = std::min(p, 4);
    const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
    Eigen::Vector3d t1, t2;
    tangent_frame(n, t1, t2);
    CHECK(std::abs(t1.dot(n)) < 1e-15);
    CHECK(std::abs(t1.cross(t2).dot(n) - 1) < 1e-14);
    const Eigen::Vector3d o(1.0, 2.0, -0.5);
    const double h = 0.1;
    const int k = 3 * fit_coefficients(p);
    Eigen::MatrixXd P(k, 3);
    Eigen::VectorXd w(k);
    for (int i = 0; i < k; ++i) {
      const double u = 3 * h * U(rng), v = 3 * h * U(rng);
      P.row(i) = (o + u * t1 + v * t2 + poly(u, v, d) * n).transpose();
      w[i] = std::exp(-(u * u + v * v) / (2 * h * h));
    }
    FitOptions opt;
    const LocalFit F = solve_height_fit(o, n, h, P, w, p, opt);
    CHECK(F.degree == p);
    double err = 0;
    for (int i = 0; i < 20; ++i) {
      const double u = 2 * h * U(rng), v = 2 * h * U(rng);
      const Eigen::Vector3d x = o + u * t1 + v * t2 + 0.01 * n;  // off the plane: projection along n
      err = std::max(err, (F.project(x) - (o + u * t1 + v * t2 + poly(u, v, d) * n)).norm());
    }
    INFO("p = " << p);
    CHECK(err < 1e-11);
  }
}

TEST_CASE("too few points or points on lines lower the degree") {
  const Eigen::Vector3d o(0, 0, 0), n(0, 0, 1);
  // 6 points cannot determine the 14 coefficients of degree 4: degree 2 (5 coefficients).
  Eigen::MatrixXd P(6, 3);
  for (int i = 0; i < 6; ++i) {
    const double a = 2 * M_PI * i / 6;
    P.row(i) << std::cos(a), std::sin(a) * 1.3, 0.1 * std::cos(a) * std::cos(a);
  }
  const LocalFit F = solve_height_fit(o, n, 1.0, P, Eigen::VectorXd::Ones(6), 4, FitOptions{});
  CHECK(F.degree <= 2);
  CHECK(F.degree >= 1);
  // All points on two lines v = 0 and v = 1: degree 2 is rank deficient (v^2 = v there).
  Eigen::MatrixXd L(10, 3);
  for (int i = 0; i < 10; ++i) L.row(i) << (i % 5) - 2.0 + 0.5, i < 5 ? 0.0 : 1.0, 0.0;
  const LocalFit G = solve_height_fit(o, n, 1.0, L, Eigen::VectorXd::Ones(10), 2, FitOptions{});
  CHECK(G.degree == 1);
  // The minimum-norm "basic" solve keeps the degree and puts no curvature across the lines.
  const LocalFit B = solve_height_fit(o, n, 1.0, L, Eigen::VectorXd::Ones(10), 2, FitOptions{},
                                      Eigen::MatrixXd(), Eigen::VectorXd(), true);
  CHECK(B.degree == 2);
  CHECK(std::abs(B.height(0.3, 0.5)) < 1e-12);
}

TEST_CASE("wedges split at feature edges; stencils never cross them") {
  const Mesh m = capped_cylinder(24, 6, 0.5, 1.0);
  const Topology T = build_topology(m.F, m.num_vertices());
  const Features feat = detect_features(m, T);
  const Wedges W = build_wedges(m, T, feat.edge_feature);
  for (int f = 0; f < m.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const int w = W.corner_wedge(f, j);
      REQUIRE(w >= 0);
      CHECK(W.wedge_vertex[w] == m.F(f, j));
    }
  int rim = 0;
  for (int v = 0; v < m.num_vertices(); ++v) {
    const int nw = W.vertex_wedge_start[v + 1] - W.vertex_wedge_start[v];
    const bool on_rim = std::abs(std::abs(m.V(v, 2)) - 0.5) < 1e-12 && m.V.row(v).head<2>().norm() > 0.1;
    CHECK(nw == (on_rim ? 2 : 1));
    rim += on_rim;
  }
  CHECK(rim == 48);
  // The side wedge of a rim vertex: a stencil of 4 rings stays on the side (entity 1).
  for (int v = 0; v < m.num_vertices(); ++v) {
    if (W.vertex_wedge_start[v + 1] - W.vertex_wedge_start[v] != 2) continue;
    for (int w = W.vertex_wedge_start[v]; w < W.vertex_wedge_start[v + 1]; ++w) {
      StencilOptions so;
      so.min_rings = 4;
      const Stencil S = grow_stencil(m, T, W, w, so);
      const int ent = m.entity_of(W.wedge_faces[W.wedge_start[w]]);
      for (int f : S.faces) CHECK(m.entity_of(f) == ent);
      CHECK(S.vertices.front() == v);
    }
  }
}

TEST_CASE("curve fits follow the rim circle with order p+1") {
  double prev = 0;
  for (int n : {24, 48}) {
    const Mesh m = capped_cylinder(n, 4, 0.5, 1.0);
    const Topology T = build_topology(m.F, m.num_vertices());
    const Features feat = detect_features(m, T);
    const CurveFitResult C = fit_feature_curves(m, T, feat, 4);
    CHECK(C.fitted == 2 * 2 * n);
    CHECK(C.downgraded == 0);
    double err = 0;
    for (int e = 0; e < T.num_edges(); ++e) {
      if (!feat.edge_feature[e]) continue;
      for (double t : {0.25, 0.5, 0.75}) {
        const Eigen::Vector3d x = curve_edge_point(m, T, C, e, t);
        err = std::max({err, std::abs(x.head<2>().norm() - 0.5), std::abs(std::abs(x.z()) - 0.5)});
      }
      // Ends are the input vertices.
      CHECK((curve_edge_point(m, T, C, e, 0.0) - m.V.row(T.E(e, 0)).transpose()).norm() < 1e-15);
    }
    MESSAGE("rim circle, " << n << " segments, P4 curve fit error " << err);
    if (prev > 0) CHECK(std::log2(prev / err) >= 4.5);
    prev = err;
  }
}

TEST_CASE("Lobatto node distribution: nodes on the surface, corners kept") {
  const Mesh m = icosphere(3);
  CurveOptions o;
  o.order = 4;
  o.distribution = NodeDistribution::Lobatto;
  const CurveResult r = curve_mesh(m, o);
  CHECK(r.mesh.distribution == NodeDistribution::Lobatto);
  double err = 0;
  for (Eigen::Index i = 0; i < r.mesh.edge_nodes.rows(); ++i) err = std::max(err, std::abs(r.mesh.edge_nodes.row(i).norm() - 1));
  for (Eigen::Index i = 0; i < r.mesh.face_nodes.rows(); ++i) err = std::max(err, std::abs(r.mesh.face_nodes.row(i).norm() - 1));
  CHECK(err < 1e-5);
  CHECK(r.validity.invalid_after == 0);
}
