// Decimation: targets, topology (manifold, closed, Euler characteristic), fold-overs, features,
// refused input, scale invariance.
#include "coarse/coarse_test_meshes.hpp"
#include "engine/coarse/decimate.hpp"
#include "engine/coarse/face_bound.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/io/read_mesh.hpp"

#include <doctest/doctest.h>
#include <cmath>
#include <set>

using namespace hocurve;

namespace {

/// Independent topology check: every edge has exactly two faces using it in opposite
/// directions, every vertex is used, returns the Euler characteristic.
int check_closed_manifold(const Mesh& m) {
  const Topology T = build_topology(m.F, m.num_vertices());
  for (int e = 0; e < T.num_edges(); ++e) {
    REQUIRE(T.edge_faces[e].size() == 2);
    int dir = 0;
    for (int f : T.edge_faces[e])
      for (int j = 0; j < 3; ++j)
        if (m.F(f, j) == T.E(e, 0) && m.F(f, (j + 1) % 3) == T.E(e, 1)) ++dir;
    REQUIRE(dir == 1);
  }
  for (int v = 0; v < m.num_vertices(); ++v) REQUIRE(T.vf_start[v + 1] > T.vf_start[v]);
  return m.num_vertices() - T.num_edges() + m.num_faces();
}

}  // namespace

TEST_CASE("icosphere 5120 -> 4%: closed, genus 0, no fold-over") {
  const Mesh fine = coarse_test::icosphere(4);
  DecimateOptions opt;
  opt.target_ratio = 0.04;
  const DecimateResult R = decimate(fine, opt);
  MESSAGE(R.message);
  CHECK(R.reached_target);
  CHECK(R.coarse.num_faces() <= R.target_faces);
  CHECK(R.coarse.num_faces() >= R.target_faces - 2);
  CHECK(check_closed_manifold(R.coarse) == 2);
  // Fold-over on a convex shape: every face faces outward, and vertices stay near the sphere.
  for (int f = 0; f < R.coarse.num_faces(); ++f) {
    const Eigen::Vector3d c =
        (R.coarse.V.row(R.coarse.F(f, 0)) + R.coarse.V.row(R.coarse.F(f, 1)) + R.coarse.V.row(R.coarse.F(f, 2))) / 3;
    CHECK(face_normal(R.coarse, f).normalized().dot(c.normalized()) > 0.5);
  }
  for (int v = 0; v < R.coarse.num_vertices(); ++v) CHECK(std::abs(R.coarse.V.row(v).norm() - 1) < 0.05);
}

TEST_CASE("torus 4096 -> 4%: closed, genus 1") {
  const Mesh fine = coarse_test::torus(64, 32, 1.0, 0.4);
  const DecimateResult R = decimate(fine, {});
  MESSAGE(R.message);
  CHECK(R.reached_target);
  CHECK(check_closed_manifold(R.coarse) == 0);
  // No fold-over: each face normal agrees with the exact torus normal at its centroid.
  for (int f = 0; f < R.coarse.num_faces(); ++f) {
    const Eigen::Vector3d c =
        (R.coarse.V.row(R.coarse.F(f, 0)) + R.coarse.V.row(R.coarse.F(f, 1)) + R.coarse.V.row(R.coarse.F(f, 2))) / 3;
    const Eigen::Vector3d ring = Eigen::Vector3d(c.x(), c.y(), 0).normalized();
    const Eigen::Vector3d n = (c - ring).normalized();
    CHECK(face_normal(R.coarse, f).normalized().dot(n) > 0.3);
  }
}

TEST_CASE("cube: corners stay, edges (rims) stay straight, faces stay on one side") {
  const Mesh fine = coarse_test::cube(12);  // 1728 faces
  DecimateOptions opt;
  opt.target_faces = 60;
  const DecimateResult R = decimate(fine, opt);
  MESSAGE(R.message);
  CHECK(R.corners == 8);
  CHECK(R.feature_edges == 12 * 12);
  CHECK(check_closed_manifold(R.coarse) == 2);
  CHECK(R.coarse.num_faces() <= 60);
  int corners = 0;
  for (int v = 0; v < R.coarse.num_vertices(); ++v) {
    const Eigen::Vector3d x = R.coarse.V.row(v);
    int on = 0;
    for (int k = 0; k < 3; ++k) on += std::abs(std::abs(x[k]) - 1) < 1e-12;
    CHECK(on >= 1);  // on the cube's surface
    corners += on == 3;
  }
  CHECK(corners == 8);
  // Every face lies in one side of the cube (no face cuts across an edge) and keeps its entity.
  for (int f = 0; f < R.coarse.num_faces(); ++f) {
    const int ent = R.coarse.face_entity[f];
    const int d = (ent - 1) / 2;
    const double side = (ent - 1) % 2 ? 1.0 : -1.0;
    for (int j = 0; j < 3; ++j) CHECK(std::abs(R.coarse.V(R.coarse.F(f, j), d) - side) < 1e-12);
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    axis[d] = side;
    CHECK(face_normal(R.coarse, f).normalized().dot(axis) > 1 - 1e-9);
  }
}

TEST_CASE("one-entity cube: short hard curves (90 degrees, 6 edges) and their corners stay") {
  Mesh fine = coarse_test::cube(6);
  fine.face_entity.resize(0);  // the rims are sharp edges only, no entity borders
  DecimateOptions opt;
  opt.target_faces = 40;
  REQUIRE(opt.min_soft_curve_edges > 6);  // the soft rule would drop them: the angle decides
  const DecimateResult R = decimate(fine, opt);
  MESSAGE(R.message);
  CHECK(R.corners == 8);
  CHECK(R.feature_edges == 12 * 6);
  // Every coarse edge lies in one side of the cube: no face cuts across a rim.
  for (int f = 0; f < R.coarse.num_faces(); ++f) {
    int common = 0;
    for (int d = 0; d < 3; ++d) {
      bool all = true;
      for (int j = 0; j < 3; ++j) all = all && std::abs(std::abs(R.coarse.V(R.coarse.F(f, j), d)) - 1) < 1e-12;
      common += all;
    }
    CHECK(common >= 1);
  }
}

TEST_CASE("bunny: soft crease fragments do not pin the decimation") {
  // The closed bunny has short open creases of 35-60 degrees (scan and remeshing noise): kept as
  // features up to min_soft_curve_edges, they freeze vertices and the ear tips are cut off.
  const Mesh fine = read_mesh_file(std::string(HOCURVE_SHARED_DIR) + "/meshes/bunny_closed.obj").mesh;
  DecimateOptions opt;
  opt.target_ratio = 0.04;
  opt.build_map = false;
  const DecimateResult now = decimate(fine, opt);
  opt.min_soft_curve_edges = opt.min_feature_curve_edges;  // soft curves treated as hard ones
  const DecimateResult pinned = decimate(fine, opt);
  const double h_now = hausdorff_distance(fine, now.coarse, 4).hausdorff();
  const double h_pinned = hausdorff_distance(fine, pinned.coarse, 4).hausdorff();
  MESSAGE("Hausdorff: " << h_now << " (soft creases dropped), " << h_pinned << " (kept); feature edges "
                        << now.feature_edges << " / " << pinned.feature_edges);
  CHECK(now.reached_target);
  CHECK(now.feature_edges < pinned.feature_edges);
  CHECK(h_now < 0.5 * h_pinned);
  CHECK(check_closed_manifold(now.coarse) == 2);
}

TEST_CASE("collapses that would move dense points far wait: thin parts survive") {
  // skull_lowres at 4%: in quadric order the largest distance of a dense vertex from its place on
  // the straight coarse surface (through the map) is 6.9% of the diagonal, 1.7% when the collapses
  // that would exceed 1% wait; the target is reached either way.
  const Mesh fine = read_mesh_file(std::string(HOCURVE_SHARED_DIR) + "/meshes/skull_lowres.obj").mesh;
  const double diag = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();
  auto mapped_deviation = [&](const DecimateResult& d) {
    double worst = 0;
    for (int v = 0; v < fine.num_vertices(); ++v) {
      const int f = d.map.vertex_coarse_face[v];
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) x += d.map.vertex_coarse_bary(v, j) * d.coarse.V.row(d.coarse.F(f, j)).transpose();
      worst = std::max(worst, (x - fine.V.row(v).transpose()).norm());
    }
    return worst / diag;
  };
  DecimateOptions opt;
  opt.target_ratio = 0.04;
  opt.max_deviation = 0;  // the deferral alone
  const DecimateResult deferred = decimate(fine, opt);
  opt.defer_deviation = 0;
  const DecimateResult plain = decimate(fine, opt);
  const double dd = mapped_deviation(deferred), dp = mapped_deviation(plain);
  MESSAGE("max mapped deviation / diagonal: " << dd << " deferred (" << deferred.deferred << " deferrals), " << dp
                                              << " quadric order");
  CHECK(deferred.reached_target);
  CHECK(plain.deferred == 0);
  CHECK(deferred.deferred > 0);
  CHECK(dd < 0.75 * dp);
  CHECK(check_closed_manifold(deferred.coarse) == check_closed_manifold(plain.coarse));
}

TEST_CASE("max_deviation keeps the dense vertices near the coarse surface, the shortfall is reported") {
  // skull_lowres at 2%: without a limit the last collapses leave dense vertices 5% of the diagonal
  // from the straight coarse surface (thin parts cut off); with max_deviation none is further than
  // the limit and the decimation stops short of the target, saying why.
  const Mesh fine = read_mesh_file(std::string(HOCURVE_SHARED_DIR) + "/meshes/skull_lowres.obj").mesh;
  const double diag = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();
  auto farthest = [&](const DecimateResult& d) {
    const TriangleGrid grid = build_triangle_grid(d.coarse);
    double worst = 0;
    for (int v = 0; v < fine.num_vertices(); ++v) worst = std::max(worst, grid_distance(grid, fine.V.row(v).transpose()));
    return worst / diag;
  };
  DecimateOptions opt;
  opt.target_ratio = 0.02;
  opt.max_deviation = 0;
  const DecimateResult free = decimate(fine, opt);
  opt.max_deviation = 0.015;
  const DecimateResult capped = decimate(fine, opt);
  const double df = farthest(free), dc = farthest(capped);
  MESSAGE("farthest dense vertex / diagonal: " << df << " (" << free.coarse.num_faces() << " faces) without a limit, " << dc
                                              << " (" << capped.coarse.num_faces() << " faces) with 0.015");
  CHECK(free.reached_target);
  CHECK(df > 0.03);
  CHECK(dc <= 0.015);
  CHECK(capped.rejected.deviation > 0);
  CHECK_FALSE(capped.reached_target);
  CHECK(capped.message.find("deviation " + std::to_string(capped.rejected.deviation)) != std::string::npos);
  CHECK(check_closed_manifold(capped.coarse) == check_closed_manifold(free.coarse));
}

TEST_CASE("an unreachable target is reported, not hidden") {
  const Mesh fine = coarse_test::cube(4);  // 192 faces, 8 corners: cannot reach 4 faces
  DecimateOptions opt;
  opt.target_faces = 4;
  const DecimateResult R = decimate(fine, opt);
  CHECK_FALSE(R.reached_target);
  CHECK(R.coarse.num_faces() >= 12);
  CHECK(R.fewest_faces == 12);  // two triangles per side: no mesh keeping the cube's edges has fewer
  CHECK(R.message.find("not reached") != std::string::npos);
  CHECK(R.message.find("needs at least 12 faces") != std::string::npos);
  CHECK(R.rejected.total() > 0);
  CHECK(check_closed_manifold(R.coarse) == 2);
}

TEST_CASE("fewest faces keeping the features: cube 12, capped cylinder 8, sphere 4, torus 14, disk 1") {
  auto fewest = [](const Mesh& m) {
    const Topology T = build_topology(m.F, m.num_vertices());
    const Features F = detect_features(m, T, {});
    return fewest_faces_keeping(m, T, F.edge_feature, F.vertex_corner);
  };
  CHECK(fewest(coarse_test::cube(6)) == 12);              // 8 corners, 12 curves
  CHECK(fewest(capped_cylinder(32, 4, 0.5, 1.0)) == 8);   // two rim loops: 3 + 3 vertices
  CHECK(fewest(coarse_test::icosphere(3)) == 4);          // a tetrahedron
  CHECK(fewest(coarse_test::torus(32, 16, 1.0, 0.3)) == 14);  // Csaszar's 7 vertices
  CHECK(fewest(coarse_test::keep_faces(uv_sphere(16, 32), [](const Eigen::Vector3d& c) { return c.z() > 0.5; })) == 1);
  // Two unit spheres side by side: each needs its own tetrahedron.
  Mesh two = coarse_test::icosphere(2);
  const Mesh one = two;
  two.V.conservativeResize(2 * one.num_vertices(), 3);
  two.F.conservativeResize(2 * one.num_faces(), 3);
  two.V.bottomRows(one.num_vertices()) = one.V.rowwise() + Eigen::RowVector3d(3, 0, 0);
  two.F.bottomRows(one.num_faces()) = one.F.array() + one.num_vertices();
  CHECK(fewest(two) == 8);
}

TEST_CASE("one to three faces: nothing to collapse, the input comes back with its identity map") {
  Mesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.2;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 1, 3, 2;
  DecimateOptions opt;
  opt.target_ratio = 0.1;
  const DecimateResult D = decimate(m, opt);
  CHECK(D.coarse.num_faces() == 2);
  CHECK(D.collapses == 0);
  CHECK(D.coarse.V == m.V);
}

TEST_CASE("non-manifold input is refused with InputError") {
  Mesh m = coarse_test::icosphere(1);
  Mesh bad = m;
  // Add a fin on edge of face 0: a third face on that edge.
  bad.V.conservativeResize(m.num_vertices() + 1, 3);
  bad.V.row(m.num_vertices()) << 3, 3, 3;
  bad.F.conservativeResize(m.num_faces() + 1, 3);
  bad.F.row(m.num_faces()) << m.F(0, 0), m.F(0, 1), m.num_vertices();
  CHECK_THROWS_AS(decimate(bad, {}), InputError);
  Mesh flipped = m;
  std::swap(flipped.F(3, 1), flipped.F(3, 2));
  CHECK_THROWS_AS(decimate(flipped, {}), InputError);
}

TEST_CASE("scale invariance: powers-of-two scalings give the same connectivity") {
  const Mesh fine = coarse_test::torus(40, 20, 1.0, 0.35);
  DecimateOptions opt;
  opt.target_ratio = 0.1;
  opt.build_map = false;
  const DecimateResult R1 = decimate(fine, opt);
  for (double s : {std::ldexp(1.0, -20), std::ldexp(1.0, 20)}) {
    Mesh scaled = fine;
    scaled.V *= s;
    const DecimateResult Rs = decimate(scaled, opt);
    REQUIRE(Rs.coarse.num_faces() == R1.coarse.num_faces());
    CHECK(Rs.coarse.F == R1.coarse.F);
    CHECK((Rs.coarse.V / s - R1.coarse.V).cwiseAbs().maxCoeff() < 1e-12);
  }
}
