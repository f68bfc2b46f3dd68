// The analytic test meshes and their exact distance functions (everything else is measured
// against them, so they are checked against independent facts here).
#include "engine/core/topology.hpp"
#include "engine/curving/test_meshes.hpp"

#include <Eigen/Geometry>
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

using namespace hocurve;
using Vec3 = Eigen::Vector3d;

namespace {

/// Signed enclosed volume (divergence theorem): positive when faces point outward.
double volume(const Mesh& m) {
  double v = 0;
  for (int f = 0; f < m.num_faces(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

/// Checks a closed, manifold mesh and returns its Euler characteristic.
int closed_euler(const Mesh& m) {
  const Topology T = build_topology(m.F, m.num_vertices());
  for (const auto& ef : T.edge_faces) REQUIRE(ef.size() == 2);
  return m.num_vertices() - T.num_edges() + m.num_faces();
}

}  // namespace

TEST_CASE("icosphere: counts, closed genus 0, outward, vertices on the unit sphere") {
  for (int s = 0; s <= 4; ++s) {
    const Mesh m = icosphere(s);
    CHECK(m.num_faces() == 20 * (1 << (2 * s)));
    CHECK(m.num_vertices() == 10 * (1 << (2 * s)) + 2);
    CHECK(closed_euler(m) == 2);
    CHECK(volume(m) > 0);
    for (int i = 0; i < m.num_vertices(); ++i) REQUIRE(std::abs(sphere_distance(m.V.row(i))) < 1e-14);
  }
  // Volume converges to 4/3 pi from below (inscribed polyhedron).
  const double v4 = volume(icosphere(4));
  CHECK(v4 < 4.0 / 3.0 * std::numbers::pi);
  CHECK(v4 > 0.99 * 4.0 / 3.0 * std::numbers::pi);
}

TEST_CASE("uv_sphere: closed, outward, equator ring is an entity border") {
  const Mesh m = uv_sphere(8, 12);
  CHECK(m.num_vertices() == 2 + 7 * 12);
  CHECK(m.num_faces() == 2 * 12 + 2 * 12 * 6);
  CHECK(closed_euler(m) == 2);
  CHECK(volume(m) > 0);
  int on_equator = 0;
  for (int i = 0; i < m.num_vertices(); ++i) {
    REQUIRE(std::abs(sphere_distance(m.V.row(i))) < 1e-14);
    on_equator += m.V(i, 2) == 0.0;
  }
  CHECK(on_equator == 12);
  for (int f = 0; f < m.num_faces(); ++f) {
    const double zc = (m.V(m.F(f, 0), 2) + m.V(m.F(f, 1), 2) + m.V(m.F(f, 2), 2)) / 3;
    REQUIRE(m.entity_of(f) == (zc > 0 ? 1 : 2));
  }
}

TEST_CASE("torus_grid: genus 1, outward, vertices on the torus, volume") {
  const double R = 1.0, r = 0.4;
  const Mesh m = torus_grid(64, 24, R, r);
  CHECK(closed_euler(m) == 0);
  const double exact = 2 * std::numbers::pi * std::numbers::pi * R * r * r;
  CHECK(volume(m) > 0.98 * exact);
  CHECK(volume(m) < exact);
  for (int i = 0; i < m.num_vertices(); ++i) REQUIRE(std::abs(torus_distance(m.V.row(i), R, r)) < 1e-14);
  // Known distances: centre of the hole, a point on the core circle, a far point on the axis.
  CHECK(torus_distance(Vec3(0, 0, 0), R, r) == doctest::Approx(R - r).epsilon(1e-15));
  CHECK(torus_distance(Vec3(0, R, 0), R, r) == doctest::Approx(-r).epsilon(1e-15));
  CHECK(torus_distance(Vec3(0, 0, 2), R, r) == doctest::Approx(std::sqrt(5.0) - r).epsilon(1e-15));
  const Vec3 p(1.7, -0.3, 0.5), q = torus_closest(p, R, r);
  CHECK(std::abs(torus_distance(q, R, r)) < 1e-14);
  CHECK((p - q).norm() == doctest::Approx(torus_distance(p, R, r)).epsilon(1e-13));
}

TEST_CASE("ellipsoid: vertices on the surface, closest point against brute force") {
  const double a = 1.0, b = 0.8, c = 0.6;
  const Mesh m = ellipsoid_mesh(3, a, b, c);
  CHECK(closed_euler(m) == 2);
  CHECK(volume(m) > 0);
  for (int i = 0; i < m.num_vertices(); ++i) {
    const Vec3 p = m.V.row(i);
    REQUIRE(std::abs(p.x() * p.x() / (a * a) + p.y() * p.y() / (b * b) + p.z() * p.z() / (c * c) - 1) < 1e-14);
    REQUIRE(std::abs(ellipsoid_distance(p, a, b, c)) < 1e-14);
  }
  // Axis points and the centre (medial axis: closest point on the shortest axis).
  CHECK(ellipsoid_distance(Vec3(2, 0, 0), a, b, c) == doctest::Approx(1.0).epsilon(1e-14));
  CHECK(ellipsoid_distance(Vec3(0, 0, -1), a, b, c) == doctest::Approx(0.4).epsilon(1e-14));
  CHECK(ellipsoid_distance(Vec3(0, 0, 0), a, b, c) == doctest::Approx(-0.6).epsilon(1e-14));
  CHECK(ellipsoid_distance(Vec3(0, 0.1, 0), a, b, c) < 0);

  // Brute force over a dense surface sample: the exact closest point must be at least as
  // close as every sample, and no further than the sampling resolution allows.
  const Mesh dense = ellipsoid_mesh(6, a, b, c);  // ~41k vertices, spacing ~0.02
  const Vec3 pts[] = {{0.1, 0, 0},      {0.3, 0.2, 0},   {0, 0.3, 0.1}, {1.2, 0.9, -0.7},
                      {-0.2, 0.1, 0.05}, {0.05, -0.6, 0}, {0, 0, 0.2},   {2.0, -1.0, 3.0}};
  for (const Vec3& p : pts) {
    const Vec3 x = ellipsoid_closest(p, a, b, c);
    const double d = (p - x).norm();
    CHECK(std::abs(x.x() * x.x() / (a * a) + x.y() * x.y() / (b * b) + x.z() * x.z() / (c * c) - 1) < 1e-13);
    double best = 1e300;
    for (int i = 0; i < dense.num_vertices(); ++i) best = std::min(best, (p - Vec3(dense.V.row(i))).norm());
    CHECK(d <= best + 1e-12);
    CHECK(d >= best - 2e-4);  // sampling error of a smooth minimum is quadratic in the spacing
    // First-order optimality: p - x is normal to the surface at x.
    const Vec3 n(x.x() / (a * a), x.y() / (b * b), x.z() / (c * c));
    if (d > 1e-12) CHECK((p - x).normalized().cross(n.normalized()).norm() < 1e-9);
  }
}

TEST_CASE("capped cylinder: sharp rims, distances of known points") {
  const double r = 1.0, h = 2.0;
  const Mesh m = capped_cylinder(24, 6, r, h);
  CHECK(closed_euler(m) == 2);
  CHECK(volume(m) > 0.98 * std::numbers::pi * r * r * h);
  for (int i = 0; i < m.num_vertices(); ++i)
    REQUIRE(std::abs(capped_cylinder_distance(m.V.row(i), r, h)) < 1e-14);
  CHECK(capped_cylinder_distance(Vec3(0, 0, 0), r, h) == doctest::Approx(-1.0));
  CHECK(capped_cylinder_distance(Vec3(0.5, 0, 0.8), r, h) == doctest::Approx(-0.2));
  CHECK(capped_cylinder_distance(Vec3(2, 0, 0), r, h) == doctest::Approx(1.0));
  CHECK(capped_cylinder_distance(Vec3(0, 0, 3), r, h) == doctest::Approx(2.0));
  CHECK(capped_cylinder_distance(Vec3(0, 2, 2), r, h) == doctest::Approx(std::sqrt(2.0)));
  const Vec3 pts[] = {{0.3, 0.2, 0.1}, {1.5, 0.5, -1.4}, {0, 0.1, 0.95}, {0.2, 0, 0}};
  for (const Vec3& p : pts) {
    const Vec3 q = capped_cylinder_closest(p, r, h);
    CHECK(std::abs(capped_cylinder_distance(q, r, h)) < 1e-14);
    CHECK((p - q).norm() == doctest::Approx(std::abs(capped_cylinder_distance(p, r, h))).epsilon(1e-12));
  }
  const Mesh cad = capped_cylinder_cad(16, r, 10.0);
  CHECK(cad.num_faces() == 2 * 16 + 2 * 16);
}

TEST_CASE("jitter_on_surface: stays on the surface, moves vertices, deterministic") {
  Mesh a = icosphere(3), b = icosphere(3);
  const Mesh ref = icosphere(3);
  jitter_on_surface(a, 0.2, 7, sphere_closest);
  jitter_on_surface(b, 0.2, 7, sphere_closest);
  CHECK(a.V == b.V);
  double moved = 0;
  for (int i = 0; i < a.num_vertices(); ++i) {
    REQUIRE(std::abs(sphere_distance(a.V.row(i))) < 1e-14);
    moved = std::max(moved, (a.V.row(i) - ref.V.row(i)).norm());
  }
  CHECK(moved > 0.01);
  CHECK(moved < 0.2 * 0.2);  // amount * mean edge (~0.16) bounds the move
}
