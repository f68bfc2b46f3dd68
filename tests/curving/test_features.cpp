// Feature detection: sharp edges, boundaries, non-manifold edges, entity borders, curves, corners.
#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/io/read_mesh.hpp"

#include <doctest/doctest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <map>
#include <numbers>
#include <set>
#include <vector>

using namespace hocurve;

namespace {

Features detect(const Mesh& m, const FeatureOptions& opt = {}) {
  return detect_features(m, build_topology(m.F, m.num_vertices()), opt);
}

/// Axis-aligned unit cube, each face an n x n grid of quads split in two (shared vertices).
Mesh cube(int n) {
  std::map<std::array<int, 3>, int> id;
  std::vector<Eigen::Vector3d> V;
  std::vector<std::array<int, 3>> F;
  auto vert = [&](std::array<int, 3> g) {
    auto it = id.find(g);
    if (it != id.end()) return it->second;
    V.push_back(Eigen::Vector3d(g[0], g[1], g[2]) / n);
    return id[g] = static_cast<int>(V.size()) - 1;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto g = [&](int a, int b) {
            std::array<int, 3> p{};
            p[axis] = side * n, p[u] = a, p[w] = b;
            return vert(p);
          };
          const int a = g(i, j), b = g(i + 1, j), c = g(i + 1, j + 1), d = g(i, j + 1);
          // (u x w) = +axis: counter-clockwise in (u,w) faces outward on the + side.
          if (side == 1) F.push_back({a, b, c}), F.push_back({a, c, d});
          else F.push_back({a, c, b}), F.push_back({a, d, c});
        }
    }
  Mesh m;
  m.V.resize(V.size(), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(i) = V[i].transpose();
  m.F.resize(F.size(), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(i) << F[i][0], F[i][1], F[i][2];
  return m;
}

/// Flat regular k-gon disk: centre fan, open boundary.
Mesh polygon_disk(int k) {
  Mesh m;
  m.V.resize(k + 1, 3);
  m.V.row(0) << 0, 0, 0;
  for (int i = 0; i < k; ++i)
    m.V.row(i + 1) << std::cos(2 * std::numbers::pi * i / k), std::sin(2 * std::numbers::pi * i / k), 0;
  m.F.resize(k, 3);
  for (int i = 0; i < k; ++i) m.F.row(i) << 0, 1 + i, 1 + (i + 1) % k;
  return m;
}

/// Flat elliptic disk (semi-axes a, b), k boundary vertices equally spaced in angle: centre fan.
Mesh ellipse_disk(int k, double a, double b) {
  Mesh m = polygon_disk(k);
  m.V.col(0) *= a;
  m.V.col(1) *= b;
  return m;
}

/// Every curve is a connected vertex chain over feature edges, ends at corners or closes, and
/// the curves partition the feature edges.
void check_curves(const Mesh& m, const Features& F) {
  const Topology T = build_topology(m.F, m.num_vertices());
  std::map<std::pair<int, int>, int> edge_of;
  for (int e = 0; e < T.num_edges(); ++e) edge_of[{T.E(e, 0), T.E(e, 1)}] = e;
  std::vector<int> used(T.num_edges(), 0);
  for (size_t c = 0; c < F.curves.size(); ++c) {
    const auto& chain = F.curves[c];
    REQUIRE(chain.size() >= 2);
    const bool closed = chain.front() == chain.back();
    if (!closed) {
      CHECK(F.vertex_corner[chain.front()]);
      CHECK(F.vertex_corner[chain.back()]);
    }
    for (size_t i = 0; i + 1 < chain.size(); ++i) {
      const int a = std::min(chain[i], chain[i + 1]), b = std::max(chain[i], chain[i + 1]);
      REQUIRE(edge_of.count({a, b}));
      const int e = edge_of[{a, b}];
      CHECK(F.edge_feature[e]);
      CHECK(F.edge_curve[e] == static_cast<int>(c));
      ++used[e];
      if (i > 0) CHECK(!F.vertex_corner[chain[i]]);  // interior vertices are not corners
    }
  }
  long long nfeat = 0;
  for (int e = 0; e < T.num_edges(); ++e) {
    CHECK(used[e] == (F.edge_feature[e] ? 1 : 0));
    nfeat += F.edge_feature[e];
  }
  CHECK(nfeat == F.feature_edges);
}

}  // namespace

TEST_CASE("smooth closed surfaces have no features") {
  for (const Mesh& m : {icosphere(3), torus_grid(48, 16, 1.0, 0.4), ellipsoid_mesh(3, 1, 0.8, 0.6)}) {
    const Features F = detect(m);
    CHECK(F.feature_edges == 0);
    CHECK(F.curves.empty());
    CHECK(F.corners == 0);
    CHECK(F.cone_points == 0);
  }
}

TEST_CASE("kink test: long thin faces across a smooth 30-degree edge leave the kink undetermined, not sharp") {
  // A torus tube with 12 vertices around and 400 along: the short edges between the tube's rows
  // have 30-degree dihedrals, and the vertices near them lie on a few rows, where |y| is a
  // combination of the even columns: the kink came out arbitrary and every such edge sharp.
  const Features F = detect(torus_grid(400, 12, 1.0, 0.4));
  CHECK(F.sharp_edges == 0);
  CHECK(F.kink_edges == 0);
}

TEST_CASE("cone points: a cone's apex, sharp or blunt, not a pole fan, not a coarse or jittered smooth surface") {
  for (double height : {2.0, 0.5, 0.2}) {  // half-angles 27, 63 and 79 degrees
    const Mesh m = cone_mesh(20, 64, 1.0, height);
    const Features F = detect(m);
    INFO("height " << height);
    CHECK(F.cone_points == 1);
    CHECK(F.vertex_cone[0] == 1);  // the apex
  }
  Mesh jittered = icosphere(4);
  jitter_on_surface(jittered, 0.3, 7, sphere_closest);
  for (const Mesh& m : {uv_sphere(40, 160), uv_sphere(8, 16), icosphere(1), jittered, capped_cylinder(32, 8, 0.5, 1.0)})
    CHECK(detect(m).cone_points == 0);
  FeatureOptions off;
  off.cone_points = false;
  const Mesh cone = cone_mesh(20, 64, 1.0, 0.5);
  CHECK(detect_features(cone, build_topology(cone.F, cone.num_vertices()), off).cone_points == 0);
}

TEST_CASE("caps on a smooth surface make no sharp edge, caps of a flat fan keep their rim") {
  // An icosphere where every 7th face becomes a cap (a, b, m) and two thin faces: m on the sphere
  // near the middle of ab, 3% of the way toward c. The cap's corners are nearly collinear, so its
  // normal leans by the arc's sagitta over its height (as iso-surface meshes' caps do).
  Mesh m = icosphere(3);
  const int nf = m.num_faces();
  std::vector<Eigen::Vector3i> faces;
  std::vector<Eigen::RowVector3d> verts;
  for (int f = 0; f < nf; ++f) {
    const int a = m.F(f, 0), b = m.F(f, 1), c = m.F(f, 2);
    if (f % 7) {
      faces.emplace_back(a, b, c);
      continue;
    }
    const Eigen::RowVector3d mid = 0.5 * (m.V.row(a) + m.V.row(b));
    const int k = m.num_vertices() + static_cast<int>(verts.size());
    verts.push_back((mid + 0.03 * (m.V.row(c) - mid)).normalized());
    faces.emplace_back(a, b, k);
    faces.emplace_back(a, k, c);
    faces.emplace_back(k, b, c);
  }
  Mesh capped;
  capped.V.resize(m.num_vertices() + static_cast<int>(verts.size()), 3);
  capped.V.topRows(m.num_vertices()) = m.V;
  for (std::size_t i = 0; i < verts.size(); ++i) capped.V.row(m.num_vertices() + static_cast<int>(i)) = verts[i];
  capped.F.resize(static_cast<int>(faces.size()), 3);
  for (std::size_t i = 0; i < faces.size(); ++i) capped.F.row(static_cast<int>(i)) = faces[i].transpose();
  FeatureOptions face_normals_only;
  face_normals_only.cap_angle_deg = 180;
  face_normals_only.exact_quadrics = false;  // its vertices are on the sphere: that alone clears them
  CHECK(detect(capped, face_normals_only).sharp_edges > 50);  // measured: 405 false sharp edges (183 caps)
  const Features F = detect(capped);
  CHECK(F.sharp_edges == 0);
  CHECK(F.curves.empty());

  // A flat top (z = 0) whose rim bows slightly in its plane, fanned from the rim's first point
  // (caps: the far rim points are nearly collinear with it), folded at 90 degrees along the rim
  // onto a wall strip: the caps' normals are exact, and the rim stays sharp.
  const int n = 24;
  Mesh fold;
  fold.V.resize(2 * (n + 1), 3);
  for (int i = 0; i <= n; ++i) {
    const double t = static_cast<double>(i) / n, y = -0.01 * std::sin(std::numbers::pi * t);
    fold.V.row(i) << t, y, 0;              // the rim
    fold.V.row(n + 1 + i) << t, y, -0.5;  // the wall below it, tall: the kink test sees only the rim
  }
  std::vector<Eigen::Vector3i> ff;
  const auto add = [&](int a, int b, int c, const Eigen::Vector3d& out) {  // oriented along `out`
    const Eigen::Vector3d pa = fold.V.row(a), pb = fold.V.row(b), pc = fold.V.row(c);
    if ((pb - pa).cross(pc - pa).dot(out) >= 0) ff.emplace_back(a, b, c);
    else ff.emplace_back(a, c, b);
  };
  for (int i = 1; i < n; ++i) add(0, i, i + 1, Eigen::Vector3d::UnitZ());
  for (int i = 0; i < n; ++i) {
    add(i, i + 1, n + 1 + i, -Eigen::Vector3d::UnitY());
    add(i + 1, n + 2 + i, n + 1 + i, -Eigen::Vector3d::UnitY());
  }
  fold.F.resize(static_cast<int>(ff.size()), 3);
  for (std::size_t i = 0; i < ff.size(); ++i) fold.F.row(static_cast<int>(i)) = ff[i].transpose();
  const Topology T = build_topology(fold.F, fold.num_vertices());
  int caps = 0;
  for (int i = 1; i < n; ++i) {
    const Eigen::Vector3d p0 = fold.V.row(0), u = Eigen::Vector3d(fold.V.row(i)) - p0,
                          v = Eigen::Vector3d(fold.V.row(i + 1)) - p0;
    caps += std::acos(std::clamp(-u.dot(v - u) / (u.norm() * (v - u).norm()), -1.0, 1.0)) * 180 / std::numbers::pi > 150;
  }
  CHECK(caps > n / 2);
  const Features G = detect(fold);
  for (int e = 0; e < T.num_edges(); ++e)
    if (T.edge_faces[e].size() == 2 && T.E(e, 0) <= n && T.E(e, 1) <= n && std::abs(T.E(e, 0) - T.E(e, 1)) == 1)
      CHECK(G.edge_feature[e]);  // every rim edge
}

TEST_CASE("cube: 12 sharp curves between 8 corners") {
  const int n = 4;
  const Mesh m = cube(n);
  const Features F = detect(m);
  CHECK(F.sharp_edges == 12 * n);
  CHECK(F.boundary_edges == 0);
  CHECK(F.feature_edges == 12 * n);
  CHECK(F.corners == 8);
  CHECK(F.closed_curves == 0);
  REQUIRE(F.curves.size() == 12);
  for (const auto& c : F.curves) CHECK(c.size() == static_cast<size_t>(n + 1));
  // The corners are exactly the cube's vertices.
  for (int v = 0; v < m.num_vertices(); ++v) {
    const auto p = m.V.row(v);
    const bool cube_corner = (p.array() == 0 || p.array() == 1).all();
    CHECK(bool(F.vertex_corner[v]) == cube_corner);
  }
  check_curves(m, F);
  // Threshold: a 90° dihedral is not sharp for a threshold above 90°.
  FeatureOptions loose;
  loose.angle_deg = 91;
  loose.weak_angle_deg = 91;  // and no kink test below it
  CHECK(detect(m, loose).feature_edges == 0);
}

TEST_CASE("kink test: a 25 degree crease is sharp, a coarse 16-gon cylinder is not") {
  // A folded jittered sheet: z = 0 for y <= 0, rising at 25 degrees for y > 0 (crease on y = 0).
  const int n = 12;
  Mesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  m.F.resize(2 * n * n, 3);
  const double slope = std::tan(25.0 * std::numbers::pi / 180);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = i + (j % 2 ? 0.3 : 0.0) * (i > 0 && i < n), y = j - n / 2;
      m.V.row(j * (n + 1) + i) << x, y, y > 0 ? y * slope : 0.0;
    }
  for (int j = 0, f = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  const Features F = detect(m);
  CHECK(F.kink_edges == n);
  CHECK(F.sharp_edges == n);
  long long on_crease = 0;
  const Topology T = build_topology(m.F, m.num_vertices());
  for (int e = 0; e < T.num_edges(); ++e)
    if (F.edge_feature[e] && T.edge_faces[e].size() == 2) {
      CHECK(m.V(T.E(e, 0), 1) == 0.0);
      CHECK(m.V(T.E(e, 1), 1) == 0.0);
      ++on_crease;
    }
  CHECK(on_crease == n);
  // Without the kink test the 25 degree crease is missed at the default threshold.
  FeatureOptions strict;
  strict.weak_angle_deg = strict.angle_deg;
  CHECK(detect(m, strict).sharp_edges == 0);

  // 16 segments around: 22.5 degree dihedral angles on the side, but no kink there.
  FeatureOptions no_entities;
  no_entities.entity_borders = false;
  const Mesh c = capped_cylinder(16, 8, 1.0, 2.0);
  const Features C = detect(c, no_entities);
  CHECK(C.kink_edges == 0);
  CHECK(C.sharp_edges == 2 * 16);
}

namespace {

/// An open sheet: the polyline `profile` (points (y, z)) extruded along x over [0, length] in n
/// steps, each quad split along alternating diagonals.
Mesh extruded(const std::vector<Eigen::Vector2d>& profile, double length, int n) {
  const int k = static_cast<int>(profile.size());
  Mesh m;
  m.V.resize((n + 1) * k, 3);
  m.F.resize(2 * n * (k - 1), 3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j < k; ++j) m.V.row(i * k + j) << length * i / n, profile[j][0], profile[j][1];
  for (int i = 0, f = 0; i < n; ++i)
    for (int j = 0; j + 1 < k; ++j) {
      const int a = i * k + j, b = a + 1, c = a + k, d = c + 1;
      if ((i + j) % 2) m.F.row(f++) << a, c, d, m.F.row(f++) << a, d, b;
      else m.F.row(f++) << a, c, b, m.F.row(f++) << b, c, d;
    }
  return m;
}

/// Number of sharp edges joining two vertices of profile row j (interior rows only).
int sharp_on_row(const Mesh& m, const Features& F, int k, int j) {
  const Topology T = build_topology(m.F, m.num_vertices());
  int count = 0;
  for (int e = 0; e < T.num_edges(); ++e)
    if (F.edge_feature[e] && T.E(e, 0) % k == j && T.E(e, 1) % k == j) ++count;
  return count;
}

}  // namespace

TEST_CASE("coarse fillets: a two-segment fillet's middle row is smooth, chamfers and prisms stay sharp") {
  // Profile: a flat run at z = 0, a turn of `turn` degrees made by `segments` equal chords of
  // length h (turns of turn / segments between chords, half of it where they meet the flats), a
  // flat run up the other side. h = 1; the extrusion's steps are 1 too.
  auto profile = [](double turn_deg, int segments, int flat) {
    std::vector<Eigen::Vector2d> P;
    const double step = turn_deg / segments * std::numbers::pi / 180;
    Eigen::Vector2d x(0, 0);
    for (int i = 0; i < flat; ++i) P.push_back(x), x += Eigen::Vector2d(1, 0);
    for (int i = 0; i < segments; ++i) {
      P.push_back(x);
      const double a = (i + 0.5) * step;
      x += Eigen::Vector2d(std::cos(a), std::sin(a));
    }
    const double a = segments * step;
    for (int i = 0; i <= flat; ++i) P.push_back(x), x += Eigen::Vector2d(std::cos(a), std::sin(a));
    return P;
  };
  const int flat = 4, n = 12;
  // 90 degrees in two segments: dihedral angles 22.5, 45, 22.5; the middle row is profile point
  // flat + 1. Smooth, as are its neighbours.
  const Mesh fillet = extruded(profile(90, 2, flat), n, n);
  const Features F = detect(fillet);
  CHECK(sharp_on_row(fillet, F, 2 * flat + 3, flat + 1) == 0);
  CHECK(F.sharp_edges == 0);
  // Switched off, it is sharp.
  FeatureOptions off;
  off.fillet_max_deg = 0;
  CHECK(sharp_on_row(fillet, detect(fillet, off), 2 * flat + 3, flat + 1) == n);
  // 120 degrees in two segments: 30, 60, 30 (the 30-degree rows are the kink test's to judge).
  const Mesh wide = extruded(profile(120, 2, flat), n, n);
  CHECK(sharp_on_row(wide, detect(wide), 2 * flat + 3, flat + 1) == 0);
  // A 45-degree chamfer: one segment, both its rows sharp (45 degrees, flat beyond on one side,
  // the other row's 45 degrees on the other).
  const Mesh chamfer = extruded(profile(90, 1, flat), n, n);
  const Features C = detect(chamfer);
  CHECK(sharp_on_row(chamfer, C, 2 * flat + 2, flat) == n);
  CHECK(sharp_on_row(chamfer, C, 2 * flat + 2, flat + 1) == n);
  // Turning on beyond the half-turn rows (a coarse polygonal prism: 45 degrees every row) is sharp.
  std::vector<Eigen::Vector2d> octagon;
  for (int i = 0; i <= 6; ++i) octagon.emplace_back(std::cos(i * std::numbers::pi / 4), std::sin(i * std::numbers::pi / 4));
  const Mesh prism = extruded(octagon, n, n);
  const Features O = detect(prism);
  for (int j = 1; j <= 5; ++j) CHECK(sharp_on_row(prism, O, 7, j) == n);
  // A lens rim: a 45-degree row between rows turning 22.5 degrees, which turn on as much beyond.
  std::vector<Eigen::Vector2d> lens;
  Eigen::Vector2d x(0, 0);
  const double turns[] = {0, 22.5, 22.5, 45, 22.5, 22.5, 0};
  double a = 0;
  for (double t : turns) {
    lens.push_back(x);
    a += t * std::numbers::pi / 180;
    x += Eigen::Vector2d(std::cos(a), std::sin(a));
  }
  lens.push_back(x);
  const Mesh rim = extruded(lens, n, n);
  CHECK(sharp_on_row(rim, detect(rim), 8, 3) == n);
}

TEST_CASE("cylinder: two closed rim loops, entity borders counted") {
  const int k = 24;
  const Mesh m = capped_cylinder(k, 6, 1.0, 2.0);
  FeatureOptions no_entities;
  no_entities.entity_borders = false;
  for (const FeatureOptions& opt : {FeatureOptions{}, no_entities}) {
    const Features F = detect(m, opt);
    CHECK(F.sharp_edges == 2 * k);  // side dihedral 360/24 = 15° < 35°, rims 90°
    CHECK(F.entity_border_edges == 2 * k);
    CHECK(F.feature_edges == 2 * k);
    CHECK(F.corners == 0);
    CHECK(F.closed_curves == 2);
    REQUIRE(F.curves.size() == 2);
    for (const auto& c : F.curves) {
      CHECK(c.size() == static_cast<size_t>(k + 1));
      CHECK(c.front() == c.back());
      for (int v : c) CHECK(std::abs(std::abs(m.V(v, 2)) - 1.0) < 1e-15);
    }
    check_curves(m, F);
  }
}

TEST_CASE("entity borders without geometry: the uv sphere's equator") {
  const int nlon = 32;
  const Mesh m = uv_sphere(16, nlon);
  Features F = detect(m);
  CHECK(F.sharp_edges == 0);
  CHECK(F.entity_border_edges == nlon);
  CHECK(F.feature_edges == nlon);
  REQUIRE(F.curves.size() == 1);
  CHECK(F.closed_curves == 1);
  for (int v : F.curves[0]) CHECK(m.V(v, 2) == 0.0);
  check_curves(m, F);
  FeatureOptions off;
  off.entity_borders = false;
  F = detect(m, off);
  CHECK(F.entity_border_edges == nlon);  // still counted, no longer a feature
  CHECK(F.feature_edges == 0);
}

TEST_CASE("open boundary: corners where the boundary turns more than corner_angle") {
  // A square turns 90° per vertex > 35°: 4 corners, 4 one-edge curves.
  Features F = detect(polygon_disk(4));
  CHECK(F.boundary_edges == 4);
  CHECK(F.corners == 4);
  CHECK(F.curves.size() == 4);
  check_curves(polygon_disk(4), F);
  // A hexagon and an octagon turn 60° and 45° alike: coarse circles (coarse_circle_max_deg), as
  // a coarse mesh has round a hole; 6 and 8 corners with that turned off.
  FeatureOptions polygons;
  polygons.coarse_circle_max_deg = 0;
  for (int k : {6, 8}) {
    CHECK(detect(polygon_disk(k)).corners == 0);
    CHECK(detect(polygon_disk(k)).closed_curves == 1);
    CHECK(detect(polygon_disk(k), polygons).corners == k);
    CHECK(detect(polygon_disk(k), polygons).curves.size() == static_cast<size_t>(k));
  }
  // A coarse ellipse (2:1, 12 vertices) turns 56° at its tips, 35° next to them: no corner.
  CHECK(detect(ellipse_disk(12, 1.0, 0.5)).corners == 0);
  // 16-gon turns 22.5°: one closed loop, no corner.
  F = detect(polygon_disk(16));
  CHECK(F.corners == 0);
  CHECK(F.closed_curves == 1);
  REQUIRE(F.curves.size() == 1);
  CHECK(F.curves[0].size() == 17);
  check_curves(polygon_disk(16), F);
  FeatureOptions tight;
  tight.corner_angle_deg = 20;
  CHECK(detect(polygon_disk(16), tight).corners == 0);  // turning alike: a coarse circle
  tight.coarse_circle_max_deg = 0;
  CHECK(detect(polygon_disk(16), tight).corners == 16);
  // A 10-gon turns 36° alike at every vertex: a coarse circle (coarse_circle_max_deg), one closed loop;
  // not with that turned off.
  F = detect(polygon_disk(10));
  CHECK(F.corners == 0);
  CHECK(F.closed_curves == 1);
  check_curves(polygon_disk(10), F);
  CHECK(detect(polygon_disk(10), polygons).corners == 10);
  // A vertex turning 36° between neighbours that do not (a 16-gon with one vertex pulled out) stays a corner.
  // Vertex 1 at radius 1.05 turns 36.5°, its neighbours 15.5°.
  Mesh bump = polygon_disk(16);
  bump.V.row(1) *= 1.05;
  const Features B = detect(bump);
  CHECK(B.vertex_corner[1] == 1);
  CHECK(B.corners == 1);
}

TEST_CASE("non-manifold edge: three fins on one edge") {
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 0, 0, 1, 1, 0, 0, -0.5, 0.8, 0, -0.5, -0.8, 0;
  m.F.resize(3, 3);
  m.F << 0, 1, 2, 0, 1, 3, 0, 1, 4;
  const Features F = detect(m);
  CHECK(F.nonmanifold_edges == 1);
  CHECK(F.boundary_edges == 6);
  CHECK(F.feature_edges == 7);
  // Vertices 0 and 1 have feature valence 3: corners; the fin tips turn by 90°+.
  CHECK(F.vertex_corner[0]);
  CHECK(F.vertex_corner[1]);
  check_curves(m, F);
}

TEST_CASE("orientation: reversing every face changes nothing, deterministic") {
  Mesh m = cube(3);
  const Features a = detect(m);
  Mesh r = m;
  r.F.col(1).swap(r.F.col(2));
  const Features b = detect(r);
  CHECK(a.edge_feature == b.edge_feature);
  CHECK(a.vertex_corner == b.vertex_corner);
  CHECK(a.curves == b.curves);
  const Features c = detect(m);
  CHECK(a.curves == c.curves);
  CHECK(a.edge_curve == c.edge_curve);
}

TEST_CASE("bad options are refused") {
  FeatureOptions bad;
  bad.angle_deg = -1;
  CHECK_THROWS_AS(detect(icosphere(0), bad), InputError);
}

TEST_CASE("pruning short dangling sharp curves (scanned mesh)") {
  const Mesh m = read_mesh_file(std::string(HOCURVE_SHARED_DIR) + "/meshes/bunny_closed.obj").mesh;
  const Topology T = build_topology(m.F, m.num_vertices());
  FeatureOptions keep, prune;
  keep.min_dangling_edges = 0;
  keep.crease_gap_ratio = prune.crease_gap_ratio = 0;  // pruning alone
  const Features plain = detect_features(m, T, keep);
  const Features pruned = detect_features(m, T, prune);  // the default prunes curves under 3 edges
  CHECK(FeatureOptions{}.min_dangling_edges == 3);
  std::printf("bunny_closed: %lld sharp edges, %zu curves; pruning dangling < 3 edges: %lld edges, %zu curves left\n",
              plain.sharp_edges, plain.curves.size(), pruned.feature_edges, pruned.curves.size());
  CHECK(pruned.pruned_edges > 0);
  CHECK(pruned.feature_edges == plain.feature_edges - pruned.pruned_edges);
  CHECK(pruned.sharp_edges == plain.sharp_edges);
  check_curves(m, pruned);
  // Pruned edges were features before; no short curve with a free end is left.
  std::vector<int> valence(m.num_vertices(), 0);
  for (int e = 0; e < T.num_edges(); ++e) {
    if (pruned.edge_feature[e]) CHECK(plain.edge_feature[e]);
    if (pruned.edge_feature[e]) ++valence[T.E(e, 0)], ++valence[T.E(e, 1)];
  }
  for (const auto& c : pruned.curves)
    if (c.size() - 1 < 3 && c.front() != c.back()) {
      CHECK(valence[c.front()] != 1);
      CHECK(valence[c.back()] != 1);
    }
  // CAD features are not dangling: the cube keeps its 12 curves; boundaries are never pruned.
  FeatureOptions opt;
  opt.min_dangling_edges = 1000;
  CHECK(detect(cube(3), opt).feature_edges == 36);
  CHECK(detect(cube(3), opt).pruned_edges == 0);
  CHECK(detect(polygon_disk(8), opt).feature_edges == 8);
}
