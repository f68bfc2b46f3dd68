// Unit tests of the SOLF building blocks: height-function fits reproduce polynomials, degree
// reduction, wedges and stencils that respect features, curve fits along a rim.
#include <doctest/doctest.h>

#include "engine/core/topology.hpp"
#include "engine/curving/apex_fit.hpp"
#include "engine/curving/curve_fit.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/curving/test_meshes.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
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

TEST_CASE("leave-one-out residual: zero where the fit is exact, above the in-sample residual elsewhere") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  const Eigen::Vector3d o = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::UnitZ();
  const double h = 0.1;
  for (const bool exact : {true, false}) {
    const int k = 40;
    Eigen::MatrixXd P(k, 3);
    Eigen::VectorXd w(k);
    for (int i = 0; i < k; ++i) {
      const double u = 3 * h * U(rng), v = 3 * h * U(rng);
      const double z = exact ? 0.3 * u * u - 0.2 * u * v : 0.05 * std::sin(20 * u) * std::cos(15 * v);
      P.row(i) << u, v, z;
      w[i] = std::exp(-(u * u + v * v) / (2 * h * h));
    }
    const LocalFit F = solve_height_fit(o, n, h, P, w, 2, FitOptions{});
    REQUIRE(F.degree == 2);
    const double loo = leave_one_out_residual(F, P, w);
    INFO("exact " << exact << ": residual " << F.residual << ", leave-one-out " << loo);
    if (exact) CHECK(loo < 1e-12);
    else CHECK(loo > 1.05 * F.residual);
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

TEST_CASE("wedges split at feature edges, stencils never cross them") {
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

TEST_CASE("curve fits follow the rim circle: exactly over the reference circle, with order p+1 without") {
  FitOptions polynomial;
  polynomial.curve_reference_circle = false;
  double prev = 0;
  for (int n : {24, 48}) {
    const Mesh m = capped_cylinder(n, 4, 0.5, 1.0);
    const Topology T = build_topology(m.F, m.num_vertices());
    const Features feat = detect_features(m, T);
    auto rim_error = [&](const FitOptions& opt) {
      const CurveFitResult C = fit_feature_curves(m, T, feat, 4, opt);
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
      return err;
    };
    CHECK(rim_error(FitOptions{}) < 1e-13);
    const double err = rim_error(polynomial);
    MESSAGE("rim circle, " << n << " segments, P4 polynomial curve fit error " << err);
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

TEST_CASE("reference surfaces: coords and point are inverse, fits reproduce a torus exactly") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  const double ks[][2] = {{0, 0}, {0, 2.0}, {0, -2.0}, {1.5, 1.5}, {-1.5, -1.5}, {0.7, 2.5}, {-1.1, 2.5}, {1.1, -2.5}};
  for (const auto& k : ks) {
    LocalFit F;
    F.o = Eigen::Vector3d(0.2, -0.1, 0.3);
    F.n = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
    tangent_frame(F.n, F.t1, F.t2);
    F.k1 = k[0], F.k2 = k[1];
    double err = 0;
    for (int i = 0; i < 50; ++i) {
      const Eigen::Vector3d q = F.o + 0.2 * Eigen::Vector3d(U(rng), U(rng), U(rng));  // |q - o| < 0.9 / |k|
      const Eigen::Vector3d c = F.coords(q);
      err = std::max(err, (F.point(c[0], c[1], c[2]) - q).norm());
    }
    INFO("k1 = " << k[0] << ", k2 = " << k[1]);
    CHECK(err < 1e-14);
    // Normal curvatures at o: points of height 0 at (u, 0) and (0, v) lie on circles of
    // curvature k1, k2 tangent to the plane (sagitta ~ k s^2 / 2).
    const double s = 1e-3;
    const double w1 = (F.point(s, 0, 0) - F.o).dot(F.n), w2 = (F.point(0, s, 0) - F.o).dot(F.n);
    CHECK(std::abs(2 * w1 / (s * s) - k[0]) < 1e-4);
    CHECK(std::abs(2 * w2 / (s * s) - k[1]) < 1e-4);
  }
  // Points of the torus R = 1, r = 0.4 (axis z) around o = (1.4, 0, 0): the reference surface
  // estimated from them is that torus, so a fit reproduces it to round-off.
  const Eigen::Vector3d o(1.4, 0, 0), n(1, 0, 0);
  const int k = 40;
  Eigen::MatrixXd P(k, 3);
  Eigen::VectorXd w = Eigen::VectorXd::Ones(k);
  for (int i = 0; i < k; ++i) {
    const double phi = 0.25 * U(rng), th = 0.25 * U(rng);
    P.row(i) << (1 + 0.4 * std::cos(th)) * std::cos(phi), (1 + 0.4 * std::cos(th)) * std::sin(phi), 0.4 * std::sin(th);
  }
  const FitReference ref = reference_surface(o, n, P, w);
  CHECK(std::abs(ref.k2 + 2.5) < 0.1);       // tube: radius 0.4, centre behind o (along -n)
  CHECK(std::abs(ref.k1 + 1 / 1.4) < 0.1);   // around the axis: radius 1.4
  // Fit error at torus points inside the stencil: plane vs estimated vs exact reference.
  auto torus = [](double phi, double th) {
    return Eigen::Vector3d((1 + 0.4 * std::cos(th)) * std::cos(phi), (1 + 0.4 * std::cos(th)) * std::sin(phi), 0.4 * std::sin(th));
  };
  FitReference exact = ref;
  exact.k1 = -1 / 1.4, exact.k2 = -2.5;
  exact.t2 = Eigen::Vector3d(0, 0, 1) * (ref.t2.z() > 0 ? 1 : -1);
  exact.t1 = exact.t2.cross(n);
  double e[3] = {0, 0, 0};
  const FitReference refs[3] = {FitReference(), ref, exact};
  for (int r = 0; r < 3; ++r) {
    const LocalFit F = solve_height_fit(o, n, 0.1, P, w, 4, FitOptions{}, Eigen::MatrixXd(), Eigen::VectorXd(), false, refs[r]);
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d q = torus(0.12 * U(rng), 0.12 * U(rng));
      e[r] = std::max(e[r], (F.project(q) - q).norm());
    }
  }
  MESSAGE("torus fit error: plane " << e[0] << " estimated torus " << e[1] << " exact torus " << e[2]);
  CHECK(e[2] < 1e-12);
  CHECK(e[1] < e[0] / 10);
  // The same on the inner side (a saddle), where the torus's axis is again the reference's.
  // (Elsewhere the osculating torus is not the torus itself: at the top the curvature around
  // the axis is 0, so the reference is a cylinder.)
  for (double th0 : {M_PI}) {
    const Eigen::Vector3d oo = torus(0, th0);
    const Eigen::Vector3d nn(std::cos(th0), 0, std::sin(th0));
    Eigen::MatrixXd Pp(k, 3);
    for (int i = 0; i < k; ++i) Pp.row(i) = torus(0.25 * U(rng), th0 + 0.25 * U(rng)).transpose();
    const FitReference rr = reference_surface(oo, nn, Pp, w);
    double ee[2] = {0, 0};
    const FitReference refs2[2] = {FitReference(), rr};
    for (int r = 0; r < 2; ++r) {
      const LocalFit F = solve_height_fit(oo, nn, 0.1, Pp, w, 4, FitOptions{}, Eigen::MatrixXd(), Eigen::VectorXd(), false, refs2[r]);
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector3d q = torus(0.12 * U(rng), th0 + 0.12 * U(rng));
        ee[r] = std::max(ee[r], (F.project(q) - q).norm());
      }
    }
    MESSAGE("inner side: k1 " << rr.k1 << " k2 " << rr.k2 << " plane " << ee[0] << " torus " << ee[1]);
    CHECK(ee[1] < ee[0] / 10);
  }
}

TEST_CASE("quadric reference: coords and point are inverse, fits reproduce an ellipsoid exactly") {
  // Points of the ellipsoid (1, 0.7, 0.5) around a point off its symmetry planes, in a frame
  // whose normal is tilted from the surface's: the quadric through o is the ellipsoid, so the
  // fit over it reproduces the surface to round-off, where the osculating torus cannot.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  auto ell = [](double th, double ph) {
    return Eigen::Vector3d(std::cos(th) * std::cos(ph), 0.7 * std::cos(th) * std::sin(ph), 0.5 * std::sin(th));
  };
  const double th0 = 0.3, ph0 = 0.2;
  const Eigen::Vector3d o = ell(th0, ph0);
  const Eigen::Vector3d grad(o.x(), o.y() / 0.49, o.z() / 0.25);
  const Eigen::Vector3d n = (grad.normalized() + Eigen::Vector3d(0.05, -0.03, 0.02)).normalized();
  const int k = 40;
  Eigen::MatrixXd P(k, 3);
  Eigen::VectorXd w(k);
  for (int i = 0; i < k; ++i) {
    P.row(i) = ell(th0 + 0.3 * U(rng), ph0 + 0.3 * U(rng)).transpose();
    w[i] = std::exp(-(P.row(i).transpose() - o).squaredNorm() / (2 * 0.1 * 0.1));
  }
  const FitReference q = quadric_reference(o, n, P, w);
  REQUIRE(q.quadric_ref);
  double e[2] = {0, 0}, inverse = 0;
  const FitReference refs[2] = {reference_surface(o, n, P, w), q};
  for (int r = 0; r < 2; ++r) {
    const LocalFit F = solve_height_fit(o, n, 0.1, P, w, 4, FitOptions{}, Eigen::MatrixXd(), Eigen::VectorXd(), false, refs[r]);
    REQUIRE(F.degree == 4);
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d x = ell(th0 + 0.1 * U(rng), ph0 + 0.1 * U(rng));
      e[r] = std::max(e[r], (F.project(x) - x).norm());
      const Eigen::Vector3d y = x + 0.05 * Eigen::Vector3d(U(rng), U(rng), U(rng));
      const Eigen::Vector3d c = F.coords(y);
      if (r == 1) inverse = std::max(inverse, (F.point(c[0], c[1], c[2]) - y).norm());
    }
  }
  MESSAGE("ellipsoid fit error: torus reference " << e[0] << ", quadric reference " << e[1]);
  CHECK(inverse < 1e-12);
  CHECK(e[1] < 1e-12);
  CHECK(e[1] < e[0] / 100);
}

TEST_CASE("curve fits: a quarter circle of three edges between corners is fitted exactly") {
  // A flat sector fan: centre, then the arc at 0, 30, 60, 90 degrees (radius 0.15, as a fillet's
  // cross section meshed by Gmsh at h = 0.1). The boundary turns 90 degrees at both arc ends, so
  // the arc is a curve of three edges between corners and each end's fit has three points.
  const double r = 0.15;
  Mesh m;
  m.V.resize(5, 3);
  m.V.row(0) << 0, 0, 0;
  for (int i = 0; i < 4; ++i) {
    const double a = i * std::numbers::pi / 6;
    m.V.row(i + 1) << r * std::cos(a), r * std::sin(a), 0;
  }
  m.F.resize(3, 3);
  m.F << 0, 1, 2, 0, 2, 3, 0, 3, 4;
  const Topology T = build_topology(m.F, m.num_vertices());
  const Features feat = detect_features(m, T);
  REQUIRE(feat.vertex_corner[1]);
  REQUIRE(feat.vertex_corner[4]);
  auto arc_error = [&](const FitOptions& opt) {
    const CurveFitResult C = fit_feature_curves(m, T, feat, 4, opt);
    double err = 0;
    for (int e = 0; e < T.num_edges(); ++e) {
      const int a = T.E(e, 0), b = T.E(e, 1);
      if (a == 0 || b == 0) continue;  // the straight radii
      for (double t : {0.25, 0.5, 0.75}) err = std::max(err, std::abs(curve_edge_point(m, T, C, e, t).norm() - r));
    }
    return err;
  };
  CHECK(arc_error(FitOptions{}) < 1e-12);
  FitOptions polynomial;
  polynomial.curve_reference_circle = false;
  CHECK(arc_error(polynomial) > 1e-4);  // the cubic through three points of the arc
}

TEST_CASE("cone model: a tilted cone's apex, five triangles round it, is fitted exactly") {
  // A cone (radius 1, height 2) five triangles round, rotated off every axis: the fan normal leans
  // off the axis where the fan is uneven, and the model's axis must turn onto it.
  Mesh m = cone_mesh(4, 5, 1.0, 2.0);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) *
                             Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())).toRotationMatrix();
  const Eigen::Vector3d shift(0.3, -2, 5);
  for (int v = 0; v < m.num_vertices(); ++v) m.V.row(v) = (R * m.V.row(v).transpose() + shift).transpose();
  // Uneven fan: move one first-ring vertex round the cone by 25 degrees (still on it).
  const Eigen::Vector3d apex = R * Eigen::Vector3d(0, 0, 2) + shift;
  const Eigen::Vector3d axis = R * Eigen::Vector3d::UnitZ();
  m.V.row(1) = (apex + Eigen::AngleAxisd(0.44, axis) * (m.V.row(1).transpose() - apex)).transpose();
  const Topology T = build_topology(m.F, m.num_vertices());
  std::vector<int> points;
  for (int v = 1; v < m.num_vertices(); ++v)
    if ((R.transpose() * (m.V.row(v).transpose() - shift)).z() > 1e-9) points.push_back(v);  // the side, not the base
  const LocalFit fit = fit_cone_model(m, T, 0, points, 0.01);
  REQUIRE(fit.apex);
  CHECK(fit.residual < 1e-10);
  CHECK(std::abs(std::abs(fit.n.dot(axis)) - 1) < 1e-10);
  auto off_cone = [&](const Eigen::Vector3d& x) { return std::abs(cone_distance(R.transpose() * (x - shift), 1.0, 2.0)); };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  double worst_projection = 0, worst_point = 0;
  for (int i = 0; i < 200; ++i) {
    // A point on the cone's side, moved off it by up to 0.05: its projection lands on the cone.
    const double phi = 2 * std::numbers::pi * u(rng), t = 0.05 + 0.9 * u(rng);
    const Eigen::Vector3d on = R * Eigen::Vector3d(t * std::cos(phi), t * std::sin(phi), 2 * (1 - t)) + shift;
    const Eigen::Vector3d off = on + 0.05 * (2 * u(rng) - 1) * (R * Eigen::Vector3d(std::cos(phi), std::sin(phi), 0.5));
    worst_projection = std::max(worst_projection, off_cone(fit.project(off)));
    // Points of the fan's faces by distance from the axis and azimuth: on the cone too.
    const int f = static_cast<int>(u(rng) * 5);
    Eigen::Matrix3d P;
    for (int j = 0; j < 3; ++j) P.row(j) = m.V.row(m.F(f, j));
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    worst_point = std::max(worst_point, off_cone(fit.apex_point(P, Eigen::Vector3d(1 - a - b, a, b))));
  }
  CHECK(worst_projection < 1e-9);
  CHECK(worst_point < 1e-9);
}
