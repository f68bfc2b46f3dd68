// Exact quadrics through mesh vertices (exact_quadric.hpp): the fit, the input's rounding, and
// which turning edges are chords of a coarse smooth CAD face rather than creases.
#include <doctest/doctest.h>

#include "engine/core/topology.hpp"
#include "engine/curving/exact_quadric.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <functional>
#include <string>
#include <numbers>
#include <vector>

using namespace hocurve;

namespace {

constexpr double pi = std::numbers::pi;

Eigen::MatrixXd rows(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::MatrixXd P(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) P.row(i) = pts[i].transpose();
  return P;
}

Mesh from_faces(const std::vector<Eigen::Vector3d>& V, const std::vector<std::array<int, 3>>& F) {
  Mesh m;
  m.V = rows(V);
  m.F.resize(static_cast<int>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(static_cast<int>(i)) << F[i][0], F[i][1], F[i][2];
  return m;
}

/// Closed cylinder r, z in [0, height], n vertices round each of `rows_` + 1 rings, ring k turned by
/// twist * k steps (twist 0: the sides are flat quads, a prism). cap_centre: each cap a fan round a
/// centre vertex; else a fan from one rim vertex (no inner vertex: all its corners on the cylinder).
Mesh ring_cylinder(int n, int rows_, double r, double height, double twist, bool cap_centre) {
  std::vector<Eigen::Vector3d> V;
  for (int k = 0; k <= rows_; ++k)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * pi * (j + twist * k) / n;
      V.emplace_back(r * std::cos(a), r * std::sin(a), height * k / rows_);
    }
  auto id = [&](int k, int j) { return k * n + (j % n); };
  std::vector<std::array<int, 3>> F;
  for (int k = 0; k < rows_; ++k)
    for (int j = 0; j < n; ++j) {
      F.push_back({id(k, j), id(k, j + 1), id(k + 1, j)});
      F.push_back({id(k, j + 1), id(k + 1, j + 1), id(k + 1, j)});
    }
  for (int k : {0, rows_}) {
    const bool top = k == rows_;
    if (cap_centre) {
      const int c = static_cast<int>(V.size());
      V.emplace_back(0, 0, height * k / rows_);
      for (int j = 0; j < n; ++j) F.push_back(top ? std::array{c, id(k, j), id(k, j + 1)} : std::array{c, id(k, j + 1), id(k, j)});
    } else {
      for (int j = 1; j + 1 < n; ++j)
        F.push_back(top ? std::array{id(k, 0), id(k, j), id(k, j + 1)} : std::array{id(k, 0), id(k, j + 1), id(k, j)});
    }
  }
  return from_faces(V, F);
}

/// Largest |distance(x)| over a degree-8 lattice of every curved element.
double lattice_error(const HighOrderMesh& hm, const std::function<double(const Eigen::Vector3d&)>& distance) {
  const Eigen::MatrixXd uv = triangle_lattice(8).cast<double>() / 8;
  double e = 0;
  for (int f = 0; f < hm.num_faces(); ++f) {
    const Eigen::MatrixXd X = evaluate_triangle(element_nodes(hm, f), hm.order, uv);
    for (Eigen::Index i = 0; i < X.rows(); ++i) e = std::max(e, std::abs(distance(X.row(i).transpose())));
  }
  return e;
}

/// Edges whose faces' normals turn by more than 35 degrees and stay sharp, and those cleared as chords.
std::pair<long long, long long> sharp_and_chords(const Mesh& m) {
  const Topology T = build_topology(m.F, m.num_vertices());
  const Features F = detect_features(m, T);
  return {F.sharp_edges, F.quadric_edges};
}

}  // namespace

TEST_CASE("fit_exact_quadric: exact on a quadric's points, undetermined on two circles") {
  std::vector<Eigen::Vector3d> cyl, ellipsoid, circles;
  for (int i = 0; i < 24; ++i) {
    const double a = 0.37 * i, z = std::sin(1.3 * i);
    cyl.emplace_back(2 + 0.5 * std::cos(a), -1 + 0.5 * std::sin(a), 0.4 * z);
    const double t = 0.21 * i + 0.3;
    ellipsoid.emplace_back(std::cos(a) * std::sin(t), 0.7 * std::sin(a) * std::sin(t), 0.5 * std::cos(t));
    circles.emplace_back(std::cos(a), std::sin(a), i % 2 ? 0.3 : 0.0);
  }
  for (const auto* pts : {&cyl, &ellipsoid}) {
    const ExactQuadric Q = fit_exact_quadric(rows(*pts));
    CHECK(Q.valid);
    CHECK(Q.max_residual < 1e-12);
    CHECK(Q.runner_up > 1e-4);  // no other quadric comes near
    for (const Eigen::Vector3d& x : *pts) CHECK((Q.project(x + 0.01 * Q.gradient(x).normalized()) - x).norm() < 1e-3);
  }
  // Two parallel circles lie on a cylinder and on every sphere or hyperboloid through both.
  const ExactQuadric C = fit_exact_quadric(rows(circles));
  CHECK(C.max_residual < 1e-12);
  CHECK(C.runner_up < 1e-10);
  // A plane only when asked for.
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 6; ++i) plane.emplace_back(std::cos(i), std::sin(2 * i), 0.5 * std::cos(i) - 0.25 * std::sin(2 * i));
  CHECK(!fit_exact_quadric(rows(plane)).valid);  // 6 points: too few for a quadric
  const ExactQuadric P = fit_exact_quadric(rows(plane), true);
  CHECK(P.valid);
  CHECK(P.max_residual < 1e-14);
  CHECK(P.runner_up > 0.1);
}

TEST_CASE("fit_tangent_quadric: a fillet's three rows and its rims' normals determine its cylinder") {
  // A quarter-round fillet of radius 0.15 along x between the planes z = 0 and y = 0 (axis
  // y = z = 0.15), two triangles across: its points lie on three lines, which a cylinder and
  // every other quadric through them share, until the rims' normals (the planes') are given.
  const double r = 0.15;
  std::vector<Eigen::Vector3d> pts, at, normals;
  for (int i = 0; i < 3; ++i) {
    const double x = 0.1 * i + 0.03 * (i == 1);
    pts.emplace_back(x, r, 0);                                        // rim on z = 0
    pts.emplace_back(x + 0.05, r - r * std::sqrt(0.5), r - r * std::sqrt(0.5));  // middle row
    pts.emplace_back(x, 0, r);                                        // rim on y = 0
    at.emplace_back(x, r, 0), normals.emplace_back(0, 0, -1);
    at.emplace_back(x, 0, r), normals.emplace_back(0, -1, 0);
  }
  CHECK(fit_exact_quadric(rows(pts)).runner_up < 1e-10);  // 9 points on 3 lines: undetermined
  const ExactQuadric Q = fit_tangent_quadric(rows(pts), rows(at), rows(normals));
  REQUIRE(Q.valid);
  CHECK(Q.max_residual < 1e-12);
  CHECK(Q.runner_up > 1e-4);
  CHECK(!plane_pair(Q));
  for (double a : {0.2, 0.7, 1.3}) {  // the arc between the rows is on it
    const Eigen::Vector3d x(0.37, r - r * std::sin(a), r - r * std::cos(a));
    CHECK(Q.distance(x) < 1e-12);
  }
  // Without the middle row the points lie on the planes z = 0 and y = 0 too: a pair of planes,
  // no CAD face, and what plane_pair tells apart.
  std::vector<Eigen::Vector3d> two;
  for (int i = 0; i < 6; ++i) two.emplace_back(0.1 * i, 0.2 + 0.15 * std::sin(2.1 * i), 0), two.emplace_back(0.1 * i, 0, 0.2 + 0.1 * std::cos(1.7 * i));
  const ExactQuadric pair = fit_exact_quadric(rows(two));
  CHECK(pair.max_residual < 1e-12);
  CHECK(plane_pair(pair));
}

TEST_CASE("fit_tangent_cyclide: a torus fillet two rows across and its rims' normals determine its torus") {
  // The rounded rim (radius 0.1) of a cylinder of radius 0.5 under the plane z = 0: a torus with
  // R = 0.4 about the z axis, centre circle at z = -0.1. Three rows of points round a quarter of
  // it lie on three circles, which many cyclides share, until the normals of the plane and the
  // cylinder along the rims are given.
  const double R = 0.4, r = 0.1;
  auto torus = [&](double theta, double phi) {
    return Eigen::Vector3d((R + r * std::cos(phi)) * std::cos(theta), (R + r * std::cos(phi)) * std::sin(theta),
                           -r + r * std::sin(phi));
  };
  std::vector<Eigen::Vector3d> pts, at, normals;
  for (int i = 0; i < 8; ++i) {
    const double theta = 0.2 * i;
    pts.push_back(torus(theta, 0));  // rim on the cylinder
    at.push_back(pts.back()), normals.emplace_back(std::cos(theta), std::sin(theta), 0);
    pts.push_back(torus(theta + 0.1, std::numbers::pi / 4));  // middle row
    pts.push_back(torus(theta, std::numbers::pi / 2));  // rim on the plane
    at.push_back(pts.back()), normals.emplace_back(0, 0, 1);
  }
  CHECK(fit_exact_cyclide(rows(pts)).runner_up < 1e-8);  // 24 points on 3 circles: undetermined
  CHECK(!(fit_tangent_quadric(rows(pts), rows(at), rows(normals)).max_residual < 1e-6));  // no quadric
  const ExactQuadric C = fit_tangent_cyclide(rows(pts), rows(at), rows(normals));
  REQUIRE(C.valid);
  CHECK(C.cyclide());
  CHECK(C.max_residual < 1e-12);
  CHECK(C.runner_up > 1e-4);
  for (double phi : {0.2, 0.6, 1.1, 1.4})  // between the rows, and round the far side
    for (double theta : {0.33, 1.0, 4.0}) CHECK(C.distance(torus(theta, phi)) < 1e-10);
}

TEST_CASE("coordinate_rounding: float32, decimal text, full doubles") {
  Mesh m = icosphere(1);
  CHECK(coordinate_rounding(m) < 1e-15);
  Mesh f = m;
  f.V = m.V.cast<float>().cast<double>();
  CHECK(coordinate_rounding(f) == std::ldexp(1.0, -24));
  Mesh d = m;
  for (Eigen::Index i = 0; i < d.V.size(); ++i) d.V.data()[i] = std::round(d.V.data()[i] * 1e5) / 1e5;  // "%.5f"
  const double r = coordinate_rounding(d);
  CHECK(r >= 5e-7);
  CHECK(r <= 5e-5);
}

TEST_CASE("turning edges on one exact quadric are chords, creases stay sharp") {
  // A 6-sided cylinder, each ring turned by half a step: its side edges turn by 23-38 degrees
  // (sharp, or kinks), but every vertex is on the cylinder. The rims (79 degrees) are creases.
  for (bool centre : {true, false}) {
    // Caps with no inner vertex have all their corners on the cylinder too, but their normals are
    // square to it: the rims stay sharp.
    const Mesh m = ring_cylinder(6, 3, 0.5, 1.0, 0.5, centre);
    const auto [sharp, chords] = sharp_and_chords(m);
    const Topology T = build_topology(m.F, m.num_vertices());
    FeatureOptions off;
    off.exact_quadrics = false;
    const long long sharp_off = detect_features(m, T, off).sharp_edges;
    MESSAGE("twisted 6-sided cylinder, caps " << std::string(centre ? "round a centre" : "without inner vertices") << ": "
                                              << sharp << " sharp, " << chords << " chords (" << sharp_off << " sharp without)");
    CHECK(sharp == 12);
    CHECK(chords > 0);
    CHECK(sharp_off > 12);
  }
  // A hexagonal prism: every side a flat rectangle of two triangles, corners on a cylinder.
  {
    const auto [sharp, chords] = sharp_and_chords(ring_cylinder(6, 1, 0.5, 1.0, 0, true));
    CHECK(sharp == 18);
    CHECK(chords == 0);
  }
  // Two planes meeting at a 60 degree ridge (a roof, 6 x 6 per side): on their product, which is
  // singular along the ridge.
  {
    std::vector<Eigen::Vector3d> V;
    std::vector<std::array<int, 3>> F;
    const int n = 7;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < 2 * n - 1; ++j) {
        const double y = (j - (n - 1)) * 0.1;
        V.emplace_back(0.1 * i + 0.013 * j, y, -std::abs(y) * std::tan(pi / 6));
      }
    for (int i = 0; i + 1 < n; ++i)
      for (int j = 0; j + 1 < 2 * n - 1; ++j) {
        const int a = i * (2 * n - 1) + j;
        F.push_back({a, a + 2 * n - 1, a + 1});
        F.push_back({a + 1, a + 2 * n - 1, a + 2 * n});
      }
    const auto [sharp, chords] = sharp_and_chords(from_faces(V, F));
    CHECK(sharp == n - 1);
    CHECK(chords == 0);
  }
}

TEST_CASE("a coarse twisted cylinder curves onto the cylinder") {
  // 8 round, 3 rows, rings turned by half a step: side edges read as creases without the exact
  // quadrics; with them the side is one smooth face fitted by its cylinder, and the rims follow
  // the crossing of the cylinder and the caps.
  const double r = 0.5, height = 1.0;
  const Mesh m = ring_cylinder(8, 3, r, height, 0.5, true);
  auto error = [&](const CurveOptions& o) {
    const CurveResult R = curve_mesh(m, o);
    return std::pair{lattice_error(R.mesh, [&](const Eigen::Vector3d& x) {
                       return capped_cylinder_distance(x - Eigen::Vector3d(0, 0, height / 2), r, height);
                     }),
                     R};
  };
  CurveOptions o;
  o.order = 4;
  const auto [p4, R] = error(o);
  CurveOptions off = o;
  off.features.exact_quadrics = off.fit.exact_quadrics = false;
  const double p4_off = error(off).first;
  o.order = 1;
  const double lin = error(o).first;
  MESSAGE("twisted 8-sided cylinder: linear " << lin << ", P4 " << p4 << " (" << R.fits.exact_fits << " exact fits), without exact quadrics " << p4_off);
  CHECK(R.features.sharp_edges == 16);
  CHECK(R.validity.invalid_after == 0);
  CHECK(p4 * 1000 < lin);
  CHECK(p4 * 100 < p4_off);
}

TEST_CASE("fit_exact_cyclide: exact on a torus, undetermined on a sphere") {
  // A tilted, off-centre torus patch (R 1, r 0.4): no quadric fits it, one cyclide does.
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  const Eigen::Vector3d shift(3, -2, 1);
  std::vector<Eigen::Vector3d> torus, sphere;
  for (int i = 0; i < 30; ++i) {
    const double u = 0.9 * std::sin(1.7 * i), v = 1.2 * std::cos(2.3 * i);
    torus.push_back(turn * Eigen::Vector3d((1 + 0.4 * std::cos(v)) * std::cos(u), (1 + 0.4 * std::cos(v)) * std::sin(u), 0.4 * std::sin(v)) + shift);
    sphere.push_back(shift + Eigen::Vector3d(std::cos(u) * std::cos(v), std::sin(u) * std::cos(v), std::sin(v)));
  }
  CHECK(fit_exact_quadric(rows(torus)).max_residual > 1e-3);
  const ExactQuadric C = fit_exact_cyclide(rows(torus));
  CHECK(C.valid);
  CHECK(C.cyclide());
  CHECK(C.max_residual < 1e-12);
  CHECK(C.runner_up > 1e-4);
  for (const Eigen::Vector3d& x : torus) CHECK((C.project(x + 0.01 * C.gradient(x).normalized()) - x).norm() < 1e-3);
  const Eigen::Vector3d off = torus[3] + 0.05 * C.gradient(torus[3]).normalized();
  CHECK(C.distance(off) == doctest::Approx(0.05).epsilon(0.01));
  CHECK(!plane_sphere(C));
  // A sphere times any sphere is a cyclide: the sphere's points determine none.
  CHECK(fit_exact_cyclide(rows(sphere)).runner_up < 1e-10);

  // miss_bound: the cheap test never refuses points within it of the surface, and refuses
  // points it proves off every cyclide (each moved 1e-3 along the torus normal, alternately in
  // and out: no cyclide is within 1e-6 of all of them; the fit's own miss is 2.7e-3).
  const ExactQuadric B = fit_exact_cyclide(rows(torus), 1e-9);
  CHECK(!B.missed);
  CHECK(B.max_residual == doctest::Approx(C.max_residual));
  std::vector<Eigen::Vector3d> noisy = torus;
  for (size_t i = 0; i < noisy.size(); ++i) noisy[i] += (i % 2 ? 1e-3 : -1e-3) * C.gradient(torus[i]).normalized();
  const ExactQuadric N = fit_exact_cyclide(rows(noisy));
  MESSAGE("noisy torus: cyclide misses by " << N.max_residual);
  CHECK(N.max_residual > 1e-5);
  CHECK(fit_exact_cyclide(rows(noisy), 1e-6).missed);
  CHECK(!fit_exact_cyclide(rows(noisy), 2 * N.max_residual).missed);
}

TEST_CASE("determined: a spindle torus beside its axis needs the precise bound, float32 gives it") {
  // screw.step's dome: a torus of axis radius 8.25 and tube radius 54.87 (a spindle), of which the
  // part more than 1.25 from the axis is left beside the slot. A stencil there at d/80 (edges
  // 1.3): points within two edges of a vertex 2.6 from the axis (float32, ~30 from the origin).
  // They lie on the torus to rounding, and a second cyclide comes within a few hundred x the
  // tolerance: determined only where the tolerance is a small enough part of their extent.
  const double R = 8.25, r = 54.87;
  const Eigen::Vector3d at(-17.9, -0.83, 7.73 - std::sqrt(r * r - R * R));
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; pts.size() < 40; ++i) {
    const double s = 2.6 * std::sqrt(0.5 + 0.5 * std::sin(2.1 * i)), theta = 2 * pi * (0.5 + 0.5 * std::cos(1.3 * i));
    const Eigen::Vector2d q(2.6 + s * std::cos(theta), s * std::sin(theta));
    if (q.norm() < 1.25) continue;
    const double rho = q.norm();
    const Eigen::Vector3d x = at + Eigen::Vector3d(q[0], q[1], std::sqrt(r * r - (rho + R) * (rho + R)));
    pts.push_back(x.cast<float>().cast<double>());
  }
  const Eigen::MatrixXd P = rows(pts);
  const ExactQuadric C = fit_exact_cyclide(P);
  const ExactQuadricOptions opt;
  const double tolerance = opt.relative_tolerance() * P.rowwise().norm().maxCoeff();
  const double extent = (P.colwise().maxCoeff() - P.colwise().minCoeff()).norm();
  MESSAGE("spindle torus cap: residual " << C.max_residual / tolerance << ", next cyclide " << C.runner_up / tolerance
                                         << " x the tolerance; tolerance / extent " << tolerance / extent);
  CHECK(C.cyclide());
  CHECK(C.max_residual <= tolerance);
  CHECK(C.runner_up >= opt.unique_cyclide_precise * tolerance);
  CHECK(C.runner_up < opt.unique_cyclide * tolerance);
  CHECK(tolerance <= opt.cyclide_precision * extent);
  CHECK(determined(C, tolerance, opt, extent));
  CHECK(!determined(C, tolerance, opt));                 // no extent given: the general bound
  CHECK(!determined(C, 10 * tolerance, opt, extent));    // a coarser input (text) is not precise
}

TEST_CASE("plane_sphere: a plane cap's points and a fillet's far rim lie on a plane times a sphere") {
  // A cylinder (radius 0.5) rounded (radius 0.12) down to its cap z = 0, its fillet one triangle
  // across: a stencil reaching over the cap's rim holds the cap's points, the fillet's upper rim
  // (a circle at z = 0.12) and one vertex inside the fillet. The cap's plane times the sphere
  // through that circle and vertex holds them all: an exact, determined cyclide, and no CAD face.
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 12; ++i) pts.emplace_back(0.3 * std::cos(0.5 * i), 0.3 * std::sin(0.5 * i) * (0.5 + 0.04 * i), 0);
  for (int i = 0; i < 8; ++i) pts.emplace_back(0.5 * std::cos(0.3 * i), 0.5 * std::sin(0.3 * i), 0.12);
  const double phi = 0.7;  // inside the fillet: on the torus R = 0.38, r = 0.12 about the z axis
  pts.emplace_back(0.38 + 0.12 * std::cos(phi), 0.1, 0.12 - 0.12 * std::sin(phi));
  const ExactQuadric C = fit_exact_cyclide(rows(pts));
  CHECK(C.cyclide());
  CHECK(C.max_residual < 1e-12);
  CHECK(plane_sphere(C));
}

TEST_CASE("fit_exact_sphere and fan_sphere: a coarse cap's fan lies on its sphere, a two-ring cylinder's do not") {
  // A cap of 7 triangles round its apex: a circle and a point, which lie on one sphere but also on
  // paraboloids and a cone; the sphere is the CAD face.
  const Eigen::Vector3d c(0.3, -0.2, 0.1);
  const double R = 0.7, polar = 0.6;
  std::vector<Eigen::Vector3d> V{c + Eigen::Vector3d(0, 0, R)};
  for (int j = 0; j < 7; ++j) {
    const double a = 2 * pi * j / 7 + 0.2;
    V.push_back(c + R * Eigen::Vector3d(std::sin(polar) * std::cos(a), std::sin(polar) * std::sin(a), std::cos(polar)));
  }
  const ExactQuadric S = fit_exact_sphere(rows(V));
  CHECK(S.valid);
  CHECK(S.max_residual < 1e-12);
  CHECK(S.runner_up > 1e-3);
  const Eigen::Vector3d x = c + R * Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  CHECK((S.project(x + 0.02 * (x - c).normalized()) - x).norm() < 1e-9);
  // The circle alone lies on a plane and on every sphere through it.
  CHECK(fit_exact_sphere(rows(std::vector<Eigen::Vector3d>(V.begin() + 1, V.end()))).runner_up < 1e-10);
  std::vector<std::array<int, 3>> F;
  for (int j = 0; j < 7; ++j) F.push_back({0, 1 + j, 1 + (j + 1) % 7});
  const Mesh cap = from_faces(V, F);
  const Topology T = build_topology(cap.F, cap.num_vertices());
  CHECK(fan_sphere(cap, T, 0, ExactQuadricOptions{}).valid);
  CHECK(!fan_sphere(cap, T, 1, ExactQuadricOptions{}).valid);  // the rim: no closed fan
  // A cylinder five vertices round, two rings, caps without a centre: every vertex's closed fan
  // has its corners on both rims, so on a sphere; its flat caps' coplanar triangles rule it out.
  const Mesh cyl = ring_cylinder(5, 1, 0.25, 0.5, 0.5, false);
  const Topology C = build_topology(cyl.F, cyl.num_vertices());
  const ExactQuadric all = fit_exact_sphere(cyl.V);
  CHECK(all.max_residual < 1e-12);
  CHECK(all.runner_up > 1e-3);
  for (int v = 0; v < cyl.num_vertices(); ++v) CHECK(!fan_sphere(cyl, C, v, ExactQuadricOptions{}).valid);
  // Nor where the tolerance is coarse for the fan (a text file's six digits, spot's eyes).
  ExactQuadricOptions coarse;
  coarse.rounding = 5e-6;
  CHECK(!fan_sphere(cap, T, 0, coarse).valid);
}

TEST_CASE("round_primitive: spheres, circular cylinders and cones; not the other quadrics of three circles") {
  // Points on a surface given by its radius at height z about an oblique axis through (0.3, -0.2, 1).
  auto revolved = [](auto radius, double squash) {
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 0.1, 1).normalized(), u = axis.unitOrthogonal(),
                          v = axis.cross(u), o(0.3, -0.2, 1);
    std::vector<Eigen::Vector3d> pts;
    for (int i = 0; i < 30; ++i) {
      const double z = 0.1 + 0.03 * i, a = 0.9 * i, r = radius(z);
      pts.push_back(o + z * axis + r * std::cos(a) * u + squash * r * std::sin(a) * v);
    }
    return fit_exact_quadric(rows(pts));
  };
  const auto sphere = [](double z) { return std::sqrt(1 - (z - 0.5) * (z - 0.5)); };
  const auto cylinder = [](double) { return 0.6; };
  const auto cone = [](double z) { return 0.2 + 0.5 * z; };
  const auto hyperboloid = [](double z) { return std::sqrt(0.1 + (z - 0.5) * (z - 0.5)); };
  const auto paraboloid = [](double z) { return std::sqrt(z); };
  for (const auto& Q : {revolved(sphere, 1), revolved(cylinder, 1), revolved(cone, 1)}) {
    REQUIRE(Q.max_residual < 1e-12);
    CHECK(round_primitive(Q));
  }
  for (const auto& Q : {revolved(hyperboloid, 1), revolved(paraboloid, 1), revolved(cylinder, 0.7),
                        revolved(cone, 0.7), revolved(sphere, 0.7)}) {
    REQUIRE(Q.max_residual < 1e-12);
    CHECK(!round_primitive(Q));
  }
}

TEST_CASE("a coarse torus curves onto the torus") {
  // 20 x 8 segments, vertices moved along the torus (as a CAD mesher's; a grid's lie on few
  // circles, which determine no cyclide): its edges round the tube turn by about 45 degrees and
  // read as creases without the cyclides; with them the torus is one smooth surface, fitted exactly.
  const double R = 1.0, r = 0.4;
  Mesh m = torus_grid(20, 8, R, r);
  jitter_on_surface(m, 0.2, 7, [&](const Eigen::Vector3d& x) { return torus_closest(x, R, r); });
  auto error = [&](const CurveOptions& o) {
    const CurveResult res = curve_mesh(m, o);
    return std::pair{lattice_error(res.mesh, [&](const Eigen::Vector3d& x) { return torus_distance(x, R, r); }), res};
  };
  CurveOptions o;
  o.order = 4;
  const auto [p4, res] = error(o);
  CurveOptions off = o;
  off.features.quadric.cyclides = off.fit.exact.cyclides = false;
  const double p4_off = error(off).first;
  o.order = 1;
  const double lin = error(o).first;
  MESSAGE("20 x 8 torus: linear " << lin << ", P4 " << p4 << " (" << res.fits.exact_fits << " exact fits, " << res.features.sharp_edges
                                  << " sharp edges), without cyclides " << p4_off);
  // What is left is interpolation at h = 0.8 r (measured 94x below linear, 75x below without).
  CHECK(res.features.sharp_edges == 0);
  CHECK(res.validity.invalid_after == 0);
  CHECK(p4 * 50 < lin);
  CHECK(p4 * 50 < p4_off);
}
