// Feature distance field: fast marching and Dijkstra against exact geodesic distances.
#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/distance_field.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/support_points.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/io/read_mesh.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

using namespace hocurve;

namespace {

/// Unit square, n x n grid with interior vertices jittered by up to `jit` cells and quad
/// diagonals chosen at random: an irregular triangulation with acute and obtuse triangles.
Mesh irregular_square(int n, double jit, std::uint64_t seed) {
  Mesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  const double h = 1.0 / n;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const int v = i * (n + 1) + j;
      double x = j * h, y = i * h;
      if (j > 0 && j < n) x += jit * h * (2 * counter_uniform(seed, v, 0) - 1);
      if (i > 0 && i < n) y += jit * h * (2 * counter_uniform(seed, v, 1) - 1);
      m.V.row(v) << x, y, 0;
    }
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + 1, c = a + n + 2, d = a + n + 1;
      if (counter_uniform(seed, a, 2) < 0.5) m.F.row(f++) << a, b, c, m.F.row(f++) << a, c, d;
      else m.F.row(f++) << a, b, d, m.F.row(f++) << b, c, d;
    }
  return m;
}

struct Err {
  double max = 0, mean = 0;
};

template <class Exact>
Err error_of(const Mesh& m, const DistanceField& D, Exact exact) {
  Err e;
  for (int v = 0; v < m.num_vertices(); ++v) {
    const double d = std::abs(D.distance[v] - exact(Eigen::Vector3d(m.V.row(v))));
    e.max = std::max(e.max, d);
    e.mean += d;
  }
  e.mean /= m.num_vertices();
  return e;
}

}  // namespace

TEST_CASE("flat irregular square, one side as feature: FMM beats Dijkstra and converges") {
  for (int n : {16, 32, 64}) {
    const Mesh m = irregular_square(n, 0.35, 11);
    const Topology T = build_topology(m.F, m.num_vertices());
    Features F;  // only the side y = 0 is a feature
    F.vertex_feature.assign(m.num_vertices(), 0);
    for (int v = 0; v < m.num_vertices(); ++v) F.vertex_feature[v] = m.V(v, 1) == 0.0;
    DistanceOptions dij;
    dij.fast_marching = false;
    const DistanceField fm = feature_distance(m, T, F), dj = feature_distance(m, T, F, dij);
    auto exact = [](const Eigen::Vector3d& p) { return p.y(); };
    const Err ef = error_of(m, fm, exact), ed = error_of(m, dj, exact);
    std::printf("square n=%d: FMM max %.3e mean %.3e | Dijkstra max %.3e mean %.3e\n", n, ef.max, ef.mean, ed.max,
                ed.mean);
    CHECK(fm.sources == n + 1);
    CHECK(fm.unreachable == 0);
    CHECK(fm.max_finite == doctest::Approx(fm.distance.maxCoeff()));
    CHECK(ef.max <= ed.max);
    CHECK(ef.mean <= ed.mean);
    // A planar front is exact in every triangle it crosses whole; only the few vertices whose
    // characteristic comes through a later-accepted neighbour keep a first-order error.
    CHECK(ef.max < 0.05 / n);
    CHECK(ef.mean < 1e-3 / n);
    CHECK(ed.max > 0.5 / n);  // Dijkstra's zigzag error stays of the order of a cell
    // Dijkstra paths along edges are never shorter than the straight line.
    for (int v = 0; v < m.num_vertices(); ++v) REQUIRE(dj.distance[v] >= m.V(v, 1) - 1e-12);
  }
}

TEST_CASE("regular right triangles: the planar front is exact") {
  const Mesh m = irregular_square(12, 0.0, 3);
  const Topology T = build_topology(m.F, m.num_vertices());
  Features F;
  F.vertex_feature.assign(m.num_vertices(), 0);
  for (int v = 0; v < m.num_vertices(); ++v) F.vertex_feature[v] = m.V(v, 1) == 0.0;
  const DistanceField D = feature_distance(m, T, F);
  for (int v = 0; v < m.num_vertices(); ++v) REQUIRE(D.distance[v] == doctest::Approx(m.V(v, 1)).epsilon(1e-12));
}

TEST_CASE("sphere with its equator as an entity border: geodesic distance = |latitude|") {
  // Structured uv sphere: meridian edges are geodesics, so Dijkstra is as good as it gets (chord
  // error only); fast marching measures the polyhedral surface, whose error is also O(h^2).
  double prev = 0;
  for (int nlat : {20, 40, 80}) {
    const Mesh m = uv_sphere(nlat, 2 * nlat);
    const Topology T = build_topology(m.F, m.num_vertices());
    const Features F = detect_features(m, T);
    REQUIRE(F.feature_edges == 2 * nlat);
    DistanceOptions dij;
    dij.fast_marching = false;
    const DistanceField fm = feature_distance(m, T, F), dj = feature_distance(m, T, F, dij);
    auto exact = [](const Eigen::Vector3d& p) { return std::asin(std::min(1.0, std::abs(p.z()))); };
    const Err ef = error_of(m, fm, exact), ed = error_of(m, dj, exact);
    const double h = std::numbers::pi / nlat;
    std::printf("uv sphere %dx%d: FMM max %.3e mean %.3e | Dijkstra max %.3e mean %.3e\n", nlat, 2 * nlat, ef.max,
                ef.mean, ed.max, ed.mean);
    CHECK(ef.max < 0.2 * h * h);
    if (prev > 0) CHECK(ef.max < prev / 3);  // second order here
    prev = ef.max;
  }
  // Jittered uv sphere (equator kept): edges no longer follow geodesics.
  for (int nlat : {20, 40}) {
    Mesh m = uv_sphere(nlat, 2 * nlat);
    const Mesh ref = m;
    jitter_on_surface(m, 0.3, 17, sphere_closest);
    for (int v = 0; v < m.num_vertices(); ++v)
      if (ref.V(v, 2) == 0.0) m.V.row(v) = ref.V.row(v);
    const Topology T = build_topology(m.F, m.num_vertices());
    FeatureOptions only_entities;  // the jittered pole fans have sharp-looking dihedrals
    only_entities.angle_deg = 180;
    const Features F = detect_features(m, T, only_entities);
    REQUIRE(F.feature_edges == 2 * nlat);
    DistanceOptions dij;
    dij.fast_marching = false;
    const DistanceField fm = feature_distance(m, T, F), dj = feature_distance(m, T, F, dij);
    auto exact = [](const Eigen::Vector3d& p) { return std::asin(std::min(1.0, std::abs(p.z()))); };
    const Err ef = error_of(m, fm, exact), ed = error_of(m, dj, exact);
    std::printf("jittered uv sphere %dx%d: FMM max %.3e mean %.3e | Dijkstra max %.3e mean %.3e\n", nlat, 2 * nlat,
                ef.max, ef.mean, ed.max, ed.mean);
    CHECK(ef.max <= ed.max);
    CHECK(ef.mean <= ed.mean);
  }
}

TEST_CASE("no features: +infinity everywhere, component without features stays infinite") {
  const Mesh m = icosphere(2);
  const Topology T = build_topology(m.F, m.num_vertices());
  const Features F = detect_features(m, T);
  REQUIRE(F.feature_edges == 0);
  const DistanceField D = feature_distance(m, T, F);
  CHECK(D.unreachable == m.num_vertices());
  CHECK(D.sources == 0);
  CHECK(D.max_finite == 0);
  for (int v = 0; v < m.num_vertices(); ++v) CHECK(std::isinf(D.distance[v]));

  // Two components: a cylinder (rims are features) and a sphere far away (none).
  const Mesh c = capped_cylinder(16, 4, 1, 2), s = icosphere(1);
  Mesh both;
  both.V.resize(c.num_vertices() + s.num_vertices(), 3);
  both.V << c.V, (s.V.rowwise() + Eigen::RowVector3d(10, 0, 0));
  both.F.resize(c.num_faces() + s.num_faces(), 3);
  both.F << c.F, (s.F.array() + c.num_vertices()).matrix();
  const Topology T2 = build_topology(both.F, both.num_vertices());
  FeatureOptions no_ent;
  no_ent.entity_borders = false;
  const DistanceField D2 = feature_distance(both, T2, detect_features(both, T2, no_ent));
  CHECK(D2.unreachable == s.num_vertices());
  for (int v = 0; v < c.num_vertices(); ++v) CHECK(std::isfinite(D2.distance[v]));
  // Cylinder side: distance to the nearer rim is 1 - |z|.
  for (int v = 0; v < c.num_vertices(); ++v)
    if (std::hypot(c.V(v, 0), c.V(v, 1)) > 0.5) CHECK(D2.distance[v] == doctest::Approx(1 - std::abs(c.V(v, 2))).epsilon(0.02));
  // Cap centres: distance to the rim is the radius (up to the polygon's inscribed radius).
  CHECK(D2.max_finite <= 1.0 + 1e-12);
  CHECK(D2.max_finite >= std::cos(std::numbers::pi / 16) - 1e-12);
}

TEST_CASE("mismatched inputs are refused") {
  const Mesh m = icosphere(1), other = icosphere(2);
  const Topology T = build_topology(m.F, m.num_vertices());
  Features F;
  F.vertex_feature.assign(other.num_vertices(), 0);
  CHECK_THROWS_AS(feature_distance(m, T, F), InputError);
  CHECK_THROWS_AS(feature_distance(other, T, Features{}), InputError);
}

TEST_CASE("deterministic") {
  const Mesh m = irregular_square(20, 0.3, 5);
  const Topology T = build_topology(m.F, m.num_vertices());
  const Features F = detect_features(m, T);  // the whole square boundary
  const DistanceField a = feature_distance(m, T, F), b = feature_distance(m, T, F);
  CHECK(a.distance == b.distance);
}

TEST_CASE("shared CAD and scan meshes: finite, and never above Dijkstra") {
  // Fast marching takes the minimum over edge and triangle updates of accepted vertices, so by
  // induction over Dijkstra's order it can only be shorter than the edge-path distance.
  for (const char* name : {"t13_data.stl", "hinge_netgen.stl", "lever_solidedge.stl", "ktoolcav.stl", "spot.obj"}) {
    CAPTURE(name);
    const Mesh m = read_mesh_file(std::string(HOCURVE_SHARED_DIR) + "/meshes/" + name).mesh;
    const Topology T = build_topology(m.F, m.num_vertices());
    const Features F = detect_features(m, T);
    DistanceOptions dij;
    dij.fast_marching = false;
    const DistanceField fm = feature_distance(m, T, F), dj = feature_distance(m, T, F, dij);
    REQUIRE(fm.sources > 0);
    CHECK(fm.unreachable == dj.unreachable);
    double worst = 0;
    for (int v = 0; v < m.num_vertices(); ++v) {
      if (std::isinf(dj.distance[v])) continue;
      REQUIRE(std::isfinite(fm.distance[v]));
      REQUIRE(fm.distance[v] >= 0);
      worst = std::max(worst, fm.distance[v] - dj.distance[v]);
    }
    CHECK(worst <= 1e-12 * std::max(1.0, dj.max_finite));
  }
}
