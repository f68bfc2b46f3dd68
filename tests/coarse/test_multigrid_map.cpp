// The bijective coarse <-> fine map: round trips both ways, valid barycentrics, injectivity,
// consistency of the eager vertex table with the replayed queries, per-collapse flattenings.
#include "coarse/coarse_test_meshes.hpp"
#include "engine/coarse/decimate.hpp"
#include "engine/coarse/flatten.hpp"
#include "engine/coarse/split_edges.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/test_meshes.hpp"

#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#if __has_include("engine/io/read_mesh.hpp")
#include "engine/io/read_mesh.hpp"
#endif

using namespace hocurve;

namespace {

double diagonal(const Eigen::MatrixXd& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

Eigen::Vector3d at(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f, const Eigen::Vector3d& b) {
  return b[0] * V.row(F(f, 0)).transpose() + b[1] * V.row(F(f, 1)).transpose() + b[2] * V.row(F(f, 2)).transpose();
}

void check_bary(const Eigen::Vector3d& b) {
  CHECK(b.minCoeff() >= -1e-12);
  CHECK(std::abs(b.sum() - 1) < 1e-12);
}

/// The whole battery of map checks on one decimation.
void check_map(const Mesh& fine, const DecimateResult& R, int samples) {
  const CoarseMap& M = R.map;
  const double diag = diagonal(fine.V);
  const int nv = fine.num_vertices();
  REQUIRE(static_cast<int>(M.vertex_coarse_face.size()) == nv);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(0, 1);
  auto random_bary = [&] {
    double a = U(rng), b = U(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    return Eigen::Vector3d(a, b, 1 - a - b);
  };

  // 1. Every fine vertex has a valid image; fine -> coarse -> fine returns the vertex.
  double worst_vertex = 0;
  MapQueryStats st;
  for (int v = 0; v < nv; ++v) {
    const int cf = M.vertex_coarse_face[v];
    REQUIRE(cf >= 0);
    REQUIRE(cf < R.coarse.num_faces());
    const Eigen::Vector3d b = M.vertex_coarse_bary.row(v).transpose();
    check_bary(b);
    const SurfacePoint back = coarse_to_fine(M, cf, b, &st);
    worst_vertex = std::max(worst_vertex, (back.position - fine.V.row(v).transpose()).norm());
  }
  MESSAGE("vertex round trip, worst / diag = " << worst_vertex / diag << ", clamped " << st.clamped << " of "
                                                << st.steps << " steps");
  CHECK(worst_vertex <= 1e-9 * diag);

  // 2. The replayed query agrees with the table built during decimation.
  double worst_agree = 0;
  for (int v = 0; v < nv; v += 7) {
    const int f = [&] {
      for (int g = 0; g < fine.num_faces(); ++g)
        for (int j = 0; j < 3; ++j)
          if (fine.F(g, j) == v) return g;
      return -1;
    }();
    if (v > 7 * 60) break;  // a few, the face search above is linear
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) b[j] = fine.F(f, j) == v;
    const SurfacePoint c = fine_to_coarse(M, f, b);
    const Eigen::Vector3d table = at(R.coarse.V, R.coarse.F, M.vertex_coarse_face[v], M.vertex_coarse_bary.row(v));
    worst_agree = std::max(worst_agree, (c.position - table).norm());
  }
  CHECK(worst_agree <= 1e-9 * diag);

  // 3. Random fine points: fine -> coarse -> fine.
  std::vector<Eigen::Vector3d> images;
  double worst_fine = 0;
  std::uniform_int_distribution<int> Ff(0, fine.num_faces() - 1);
  for (int i = 0; i < samples; ++i) {
    const int f = Ff(rng);
    const Eigen::Vector3d b = random_bary();
    const SurfacePoint c = fine_to_coarse(M, f, b);
    check_bary(c.bary);
    REQUIRE(c.face >= 0);
    images.push_back(c.position);
    const SurfacePoint back = coarse_to_fine(M, c.face, c.bary);
    check_bary(back.bary);
    worst_fine = std::max(worst_fine, (back.position - at(fine.V, fine.F, f, b)).norm());
  }
  MESSAGE("fine->coarse->fine worst / diag = " << worst_fine / diag);
  CHECK(worst_fine <= 1e-9 * diag);

  // 4. Random coarse points: coarse -> fine -> coarse.
  double worst_coarse = 0;
  std::uniform_int_distribution<int> Fc(0, R.coarse.num_faces() - 1);
  for (int i = 0; i < samples; ++i) {
    const int f = Fc(rng);
    const Eigen::Vector3d b = random_bary();
    const SurfacePoint d = coarse_to_fine(M, f, b);
    REQUIRE(d.face >= 0);
    REQUIRE(d.face < fine.num_faces());
    const SurfacePoint c = fine_to_coarse(M, d.face, d.bary);
    worst_coarse = std::max(worst_coarse, (c.position - at(R.coarse.V, R.coarse.F, f, b)).norm());
  }
  MESSAGE("coarse->fine->coarse worst / diag = " << worst_coarse / diag);
  CHECK(worst_coarse <= 1e-9 * diag);

  // 5. Injectivity on the fine vertices: distinct vertices have distinct coarse images.
  Eigen::MatrixXd P = fine_vertices_on_coarse(M);
  std::vector<int> order(nv);
  for (int v = 0; v < nv; ++v) order[v] = v;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return P(a, 0) < P(b, 0); });
  const double eps = 1e-10 * diag;
  int collisions = 0;
  for (int i = 0; i < nv; ++i)
    for (int j = i + 1; j < nv && P(order[j], 0) - P(order[i], 0) <= eps; ++j)
      collisions += (P.row(order[i]) - P.row(order[j])).norm() <= eps;
  CHECK(collisions == 0);

  // 6. The per-coarse-face lists partition the fine vertices.
  REQUIRE(static_cast<int>(M.cf_start.size()) == R.coarse.num_faces() + 1);
  std::vector<int> seen(nv, 0);
  for (int f = 0; f < R.coarse.num_faces(); ++f)
    for (auto [b, e] = M.fine_vertices_in(f); b != e; ++b) {
      CHECK(M.vertex_coarse_face[*b] == f);
      ++seen[*b];
    }
  CHECK(std::count(seen.begin(), seen.end(), 1) == nv);

  // 7. Per collapse: the stored pre and post UV layouts have no flipped triangle.
  int flipped = 0;
  for (int c = 0; c < M.num_collapses(); ++c) {
    const Eigen::Vector2d* uv = M.rec_uv.data() + M.rec_uv_start[c];
    const int n = M.rec_uv_start[c + 1] - M.rec_uv_start[c] - 1;
    const int post = M.rec_post_reuses[c] ? 0 : n;
    for (int k = M.rec_face_start[c]; k < M.rec_face_start[c + 1]; ++k) {
      std::array<int, 3> t{M.rec_face_local[k][0], M.rec_face_local[k][1], M.rec_face_local[k][2]};
      auto area = [&](const std::array<int, 3>& q) {
        const Eigen::Vector2d a = uv[q[1]] - uv[q[0]], b = uv[q[2]] - uv[q[0]];
        return a[0] * b[1] - a[1] * b[0];
      };
      flipped += area(t) <= 0;
      if (M.rec_face_removed[k]) continue;
      for (int& x : t)
        if (x == 0 || x == 1) x = post;
      flipped += area(t) <= 0;
    }
  }
  CHECK(flipped == 0);
}

}  // namespace

TEST_CASE("map on an icosphere (5120 -> 4%)") {
  const Mesh fine = coarse_test::icosphere(4);
  const DecimateResult R = decimate(fine, {});
  MESSAGE(R.message);
  CHECK(R.map.num_collapses() == R.collapses);
  check_map(fine, R, 2000);
  // Coverage for fitting: the coarse faces around each coarse vertex gather at least
  // 1.5 x 10 fine vertices (enough for a cubic height-field fit's 10 coefficients).
  std::vector<int> around(R.coarse.num_vertices(), 0);
  for (int f = 0; f < R.coarse.num_faces(); ++f) {
    auto [b, e] = R.map.fine_vertices_in(f);
    for (int j = 0; j < 3; ++j) around[R.coarse.F(f, j)] += static_cast<int>(e - b);
  }
  const int fewest = *std::min_element(around.begin(), around.end());
  MESSAGE("fewest fine vertices around a coarse vertex: " << fewest);
  CHECK(fewest >= 15);
  // Prolongation matrix: rows sum to one and reproduce the tracked positions.
  const Eigen::SparseMatrix<double> P = prolongation(R.map);
  CHECK(P.rows() == fine.num_vertices());
  CHECK(P.cols() == R.coarse.num_vertices());
  const Eigen::VectorXd rows = P * Eigen::VectorXd::Ones(P.cols());
  CHECK((rows.array() - 1).abs().maxCoeff() < 1e-12);
  CHECK((P * R.coarse.V - fine_vertices_on_coarse(R.map)).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("map on a torus (4096 -> 4%)") {
  const Mesh fine = coarse_test::torus(64, 32, 1.0, 0.4);
  const DecimateResult R = decimate(fine, {});
  MESSAGE(R.message);
  check_map(fine, R, 2000);
}

TEST_CASE("edge splits after the decimation keep the map a bijection, the mesh closed and oriented") {
  const Mesh fine = coarse_test::torus(64, 32, 1.0, 0.4);
  DecimateResult R = decimate(fine, {});
  const int nf0 = R.coarse.num_faces(), nv0 = R.coarse.num_vertices();
  // Two rounds (the second splits halves made by the first): each round the longest edge of every
  // 6th face whose faces are not taken yet, and one pair that is not an edge.
  int split = 0;
  for (int round = 0; round < 2; ++round) {
    const Topology T = build_topology(R.coarse.F, R.coarse.num_vertices());
    std::vector<char> taken(R.coarse.num_faces(), 0);
    std::vector<std::array<int, 2>> edges = {{0, 0}};
    for (int f = round; f < R.coarse.num_faces(); f += 6) {
      int e = T.FE(f, 0);
      for (int j = 1; j < 3; ++j)
        if ((R.coarse.V.row(T.E(T.FE(f, j), 0)) - R.coarse.V.row(T.E(T.FE(f, j), 1))).norm() >
            (R.coarse.V.row(T.E(e, 0)) - R.coarse.V.row(T.E(e, 1))).norm())
          e = T.FE(f, j);
      const int g = T.edge_faces[e][0] == f ? T.edge_faces[e][1] : T.edge_faces[e][0];
      if (taken[f] || taken[g]) continue;
      taken[f] = taken[g] = 1;
      edges.push_back({T.E(e, 0), T.E(e, 1)});
    }
    const SplitResult S = split_coarse_edges(R, edges);
    CHECK(S.refused >= 1);
    split += S.split;
  }
  MESSAGE(split << " splits: " << nf0 << " -> " << R.coarse.num_faces() << " faces");
  CHECK(split > 20);
  CHECK(R.coarse.num_faces() == nf0 + 2 * split);
  CHECK(R.coarse.num_vertices() == nv0 + split);
  CHECK(R.coarse_vertex_origin.size() == static_cast<size_t>(R.coarse.num_vertices()));
  // Closed and consistently oriented: every directed edge once, its reverse once.
  std::map<std::pair<int, int>, int> directed;
  for (int f = 0; f < R.coarse.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) ++directed[{R.coarse.F(f, j), R.coarse.F(f, (j + 1) % 3)}];
  int bad = 0;
  for (const auto& [e, n] : directed) bad += n != 1 || !directed.count({e.second, e.first});
  CHECK(bad == 0);
  // The new vertices lie on the dense surface: no further from the torus than its facets are.
  auto torus_distance = [](const Eigen::Vector3d& x) {
    return std::abs(std::hypot(std::hypot(x[0], x[1]) - 1.0, x[2]) - 0.4);
  };
  double off = 0, sag = 0;
  for (int v = nv0; v < R.coarse.num_vertices(); ++v) off = std::max(off, torus_distance(R.coarse.V.row(v).transpose()));
  const Eigen::MatrixXd P = sample_faces(fine, 8);
  for (Eigen::Index i = 0; i < P.rows(); ++i) sag = std::max(sag, torus_distance(P.row(i).transpose()));
  MESSAGE("new vertices off the torus " << off << ", dense facets " << sag);
  CHECK(off <= sag);
  check_map(fine, R, 2000);
}

TEST_CASE("map on a cube with features (1728 -> 60)") {
  const Mesh fine = coarse_test::cube(12);
  DecimateOptions opt;
  opt.target_faces = 60;
  const DecimateResult R = decimate(fine, opt);
  check_map(fine, R, 1000);
  // Points on a cube edge map onto a cube edge (curves are kept as polylines by the flattening).
  int on_edge = 0, kept = 0;
  for (int v = 0; v < fine.num_vertices(); ++v) {
    const Eigen::Vector3d x = fine.V.row(v);
    int on = 0;
    for (int k = 0; k < 3; ++k) on += std::abs(std::abs(x[k]) - 1) < 1e-12;
    if (on < 2) continue;
    const Eigen::Vector3d y = at(R.coarse.V, R.coarse.F, R.map.vertex_coarse_face[v], R.map.vertex_coarse_bary.row(v));
    int on2 = 0;
    for (int k = 0; k < 3; ++k) on2 += std::abs(std::abs(y[k]) - 1) < 1e-9;
    ++on_edge;
    kept += on2 >= 2;
  }
  MESSAGE("fine cube-edge vertices mapped onto a coarse cube edge: " << kept << " of " << on_edge);
  CHECK(on_edge == 12 * 11 + 8);
  CHECK(kept == on_edge);
}

TEST_CASE("open surface (a torus cut open into a bent tube): the boundary coarsens along itself, map round trips") {
  // Three quarters of the ring: two smooth circular boundaries (meridians), no corners.
  const Mesh open = coarse_test::keep_faces(coarse_test::torus(48, 24, 1.0, 0.3), [](const Eigen::Vector3d& c) {
    return std::abs(std::atan2(c.y(), c.x())) < 0.75 * std::numbers::pi;
  });
  // Boundary edge count, Euler characteristic and boundary vertices.
  struct Shape { int nb, chi; std::vector<char> bnd; };
  auto shape = [](const Mesh& m) {
    const Topology T = build_topology(m.F, m.num_vertices());
    Shape s{0, m.num_vertices() - T.num_edges() + m.num_faces(), std::vector<char>(m.num_vertices(), 0)};
    for (int e = 0; e < T.num_edges(); ++e) {
      REQUIRE(T.edge_faces[e].size() <= 2);
      if (T.edge_faces[e].size() == 1) ++s.nb, s.bnd[T.E(e, 0)] = s.bnd[T.E(e, 1)] = 1;
    }
    return s;
  };
  const Shape S0 = shape(open);
  REQUIRE(S0.nb == 48);
  REQUIRE(S0.chi == 0);
  DecimateOptions opt;
  opt.target_ratio = 0.08;
  const DecimateResult R = decimate(open, opt);
  MESSAGE(R.message);
  CHECK(R.reached_target);
  const Shape S1 = shape(R.coarse);
  MESSAGE("boundary edges " << S0.nb << " -> " << S1.nb);
  CHECK(S1.nb <= S0.nb / 2);  // the boundary coarsens too ...
  CHECK(S1.nb >= 6);
  CHECK(S1.chi == 0);        // ... and the tube stays a tube
  // Coarse boundary vertices are dense boundary vertices that never moved.
  for (int v = 0; v < R.coarse.num_vertices(); ++v)
    if (S1.bnd[v]) {
      const int o = R.coarse_vertex_origin[v];
      REQUIRE(o >= 0);
      CHECK(S0.bnd[o]);
      CHECK((R.coarse.V.row(v) - open.V.row(o)).norm() == 0.0);
    }
  // Dense boundary vertices map onto coarse boundary edges: every corner with a non-zero
  // barycentric is a coarse boundary vertex.
  int on_boundary = 0;
  for (int v = 0; v < open.num_vertices(); ++v) {
    if (!S0.bnd[v]) continue;
    const int f = R.map.vertex_coarse_face[v];
    bool ok = true;
    for (int k = 0; k < 3; ++k)
      if (R.map.vertex_coarse_bary(v, k) > 1e-12 && !S1.bnd[R.coarse.F(f, k)]) ok = false;
    on_boundary += ok;
  }
  MESSAGE("dense boundary vertices on a coarse boundary edge: " << on_boundary << " of " << S0.nb);
  CHECK(on_boundary == S0.nb);  // boundary loops: as many vertices as edges
  int reused = 0;
  for (char c : R.map.rec_post_reuses) reused += c;
  MESSAGE(reused << " collapses into a boundary vertex");
  CHECK(reused > 0);  // the boundary variant of the flattening was exercised
  check_map(open, R, 1000);
}

TEST_CASE("determinism: the same input gives the same coarse mesh and map") {
  const Mesh fine = coarse_test::torus(48, 24, 1.0, 0.3);
  const DecimateResult A = decimate(fine, {}), B = decimate(fine, {});
  CHECK(A.coarse.F == B.coarse.F);
  CHECK(A.coarse.V == B.coarse.V);
  CHECK(A.map.vertex_coarse_face == B.map.vertex_coarse_face);
  CHECK(A.map.vertex_coarse_bary == B.map.vertex_coarse_bary);
}

TEST_CASE("query arguments out of range throw InputError") {
  const Mesh fine = coarse_test::icosphere(2);
  const DecimateResult R = decimate(fine, {});
  CHECK_THROWS_AS(coarse_to_fine(R.map, R.coarse.num_faces(), Eigen::Vector3d(1, 0, 0)), InputError);
  CHECK_THROWS_AS(fine_to_coarse(R.map, -1, Eigen::Vector3d(1, 0, 0)), InputError);
}

#if __has_include("engine/io/read_mesh.hpp")
TEST_CASE("bunny_closed -> 4%") {
  const std::string path = std::string(HOCURVE_SHARED_DIR) + "/meshes/bunny_closed.obj";
  if (!std::filesystem::exists(path)) return;
  const Mesh fine = read_mesh_file(path).mesh;
  // Organic surface: its sharp-edge fragments at 35 degrees are all short, so they are ignored
  // (min_feature_curve_edges) and do not pin the decimation.
  const DecimateResult R = decimate(fine, {});
  MESSAGE(R.message);
  CHECK(R.reached_target);
  const Topology T = build_topology(R.coarse.F, R.coarse.num_vertices());
  for (int e = 0; e < T.num_edges(); ++e) CHECK(T.edge_faces[e].size() == 2);
  CHECK(R.coarse.num_vertices() - T.num_edges() + R.coarse.num_faces() == 2);
  check_map(fine, R, 1000);
}
#endif

TEST_CASE("capped cylinder: rims kept by decimation and by the map") {
  const double radius = 1.0, height = 2.0;
  const Mesh fine = capped_cylinder(48, 16, radius, height);
  DecimateOptions opt;
  opt.target_ratio = 0.1;
  const DecimateResult R = decimate(fine, opt);
  MESSAGE(R.message);
  CHECK(R.reached_target);
  check_map(fine, R, 500);
  const Mesh& C = R.coarse;
  auto on_rim = [&](const Eigen::Vector3d& x, double tol) {
    return std::abs(std::abs(x.z()) - height / 2) < tol && std::abs(x.head<2>().norm() - radius) < tol;
  };
  // Coarse faces stay in their entity: cap faces flat at +-h/2, side faces on the cylinder.
  int rim_vertices = 0;
  for (int v = 0; v < C.num_vertices(); ++v) rim_vertices += on_rim(C.V.row(v), 1e-12);
  CHECK(rim_vertices >= 6);
  for (int f = 0; f < C.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d x = C.V.row(C.F(f, j));
      if (C.entity_of(f) == 1) CHECK(std::abs(x.head<2>().norm() - radius) < 0.02);  // QEM sits inside a curve
      else CHECK(std::abs(x.z() - (C.entity_of(f) == 3 ? 1 : -1) * height / 2) < 1e-12);
    }
  // Fine rim vertices map onto the coarse rim: every corner with a non-zero barycentric is a
  // rim vertex (a point on a rim edge or at a rim vertex).
  int rim = 0, kept = 0;
  for (int v = 0; v < fine.num_vertices(); ++v) {
    if (!on_rim(fine.V.row(v), 1e-12)) continue;
    ++rim;
    const int f = R.map.vertex_coarse_face[v];
    const Eigen::Vector3d b = R.map.vertex_coarse_bary.row(v);
    bool ok = true;
    for (int k = 0; k < 3; ++k)
      if (b[k] > 1e-12 && !on_rim(C.V.row(C.F(f, k)), 1e-12)) ok = false;
    kept += ok;
  }
  MESSAGE("fine rim vertices on a coarse rim edge: " << kept << " of " << rim);
  CHECK(rim == 96);
  CHECK(kept == rim);
}

TEST_CASE("target at or above the input size: nothing collapses, the map is the identity") {
  const Mesh fine = coarse_test::icosphere(2);
  DecimateOptions opt;
  opt.target_faces = fine.num_faces();
  const DecimateResult R = decimate(fine, opt);
  CHECK(R.reached_target);
  CHECK(R.collapses == 0);
  CHECK(R.coarse.F == fine.F);
  for (int v = 0; v < fine.num_vertices(); ++v) {
    const Eigen::Vector3d x = at(R.coarse.V, R.coarse.F, R.map.vertex_coarse_face[v], R.map.vertex_coarse_bary.row(v));
    CHECK((x - fine.V.row(v).transpose()).norm() == 0);
  }
  const SurfacePoint p = coarse_to_fine(R.map, 3, Eigen::Vector3d(0.2, 0.3, 0.5));
  CHECK(p.face == 3);
  CHECK((p.bary - Eigen::Vector3d(0.2, 0.3, 0.5)).norm() < 1e-15);
}
