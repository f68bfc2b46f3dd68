// Offsets that contradict the fits' own tangent planes are scaled down; consistent ones are kept.
#include "engine/core/topology.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/offset_bound.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <doctest/doctest.h>

using namespace hocurve;

namespace {

/// A mesh with its wedges and degree-4 fits (no features), and its straight P4 mesh.
struct Fitted {
  Mesh mesh;
  Topology T;
  Wedges W;
  std::vector<LocalFit> fits;
  HighOrderMesh hm;
  explicit Fitted(Mesh m) : mesh(std::move(m)) {
    T = build_topology(mesh.F, mesh.num_vertices());
    W = build_wedges(mesh, T, std::vector<char>(T.num_edges(), 0));
    FitOptions height_only;  // exact surfaces are left alone by the bound: height fits here
    height_only.exact_quadrics = false;
    fits = fit_wedges(mesh, T, W, 4, nullptr, height_only).fits;
    hm = make_straight_high_order(mesh, T, 4);
  }
  /// Moves every edge and face node onto the unit sphere (the exact surface).
  void onto_sphere() {
    for (Eigen::Index i = 0; i < hm.edge_nodes.rows(); ++i) hm.edge_nodes.row(i).normalize();
    for (Eigen::Index i = 0; i < hm.face_nodes.rows(); ++i) hm.face_nodes.row(i).normalize();
  }
  /// Moves edge e's nodes by `amount` x its length along `dir`, as a parabola over the edge.
  void bulge(int e, double amount, const Eigen::RowVector3d& dir) {
    const double L = (mesh.V.row(T.E(e, 0)) - mesh.V.row(T.E(e, 1))).norm();
    for (int k = 1; k < 4; ++k) hm.edge_nodes.row(e * 3 + k - 1) += amount * L * 4 * (k / 4.0) * (1 - k / 4.0) * dir;
  }
};

Mesh flat_grid(int n) {
  Mesh m;
  m.V.resize((n + 1) * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.V.row(j * (n + 1) + i) << i, j, 0;
  m.F.resize(2 * n * n, 3);
  int f = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  return m;
}

int interior_edge(const Topology& T) {
  for (int e = 0; e < T.num_edges(); ++e)
    if (T.edge_faces[e].size() == 2) return e;
  return -1;
}

}  // namespace

TEST_CASE("offset_bound: exact nodes on a sphere are consistent with the fitted normals") {
  Fitted s(icosphere(2));
  s.onto_sphere();
  const HighOrderMesh before = s.hm;
  const OffsetBoundResult R = bound_offsets(s.mesh, s.T, s.W, s.fits, nullptr, s.hm);
  CHECK(R.edges == 0);
  CHECK(R.faces == 0);
  CHECK(s.hm.edge_nodes == before.edge_nodes);
  CHECK(s.hm.face_nodes == before.face_nodes);
}

TEST_CASE("offset_bound: a bulge the tangent planes do not allow is scaled down, conformingly") {
  Fitted s(icosphere(2));
  s.onto_sphere();
  const int e = interior_edge(s.T);
  REQUIRE(e >= 0);
  const Eigen::RowVector3d out = (s.mesh.V.row(s.T.E(e, 0)) + s.mesh.V.row(s.T.E(e, 1))).normalized();
  s.bulge(e, 0.3, out);  // a sphere's chord of ~0.3 leaves it by ~0.01: 0.3 L is 10x too far
  const OffsetBoundResult R = bound_offsets(s.mesh, s.T, s.W, s.fits, nullptr, s.hm);
  CHECK(R.edges == 1);
  CHECK(R.faces == 2);  // the edge's two faces follow their side
  CHECK(R.min_scale < 0.5);
  // The edge's middle node is back within twice the sphere's sagitta of its chord.
  const Eigen::Vector3d a = s.mesh.V.row(s.T.E(e, 0)), b = s.mesh.V.row(s.T.E(e, 1));
  const double L = (b - a).norm(), sagitta = 1 - std::sqrt(1 - L * L / 4);
  const Eigen::Vector3d mid = s.hm.edge_nodes.row(e * 3 + 1);
  CHECK((mid - 0.5 * (a + b)).norm() < 2.5 * sagitta);
}

TEST_CASE("offset_bound: flat stays flat") {
  Fitted s(flat_grid(4));
  const int e = interior_edge(s.T);
  s.bulge(e, 0.05, Eigen::RowVector3d::UnitZ());
  const OffsetBoundResult R = bound_offsets(s.mesh, s.T, s.W, s.fits, nullptr, s.hm);
  CHECK(R.edges == 1);
  const OffsetBoundOptions opt;
  for (Eigen::Index i = 0; i < s.hm.edge_nodes.rows(); ++i) CHECK(std::abs(s.hm.edge_nodes(i, 2)) <= opt.slack * 1.5);
  for (Eigen::Index i = 0; i < s.hm.face_nodes.rows(); ++i) CHECK(std::abs(s.hm.face_nodes(i, 2)) <= opt.slack * 1.5);
}

TEST_CASE("offset_bound: curve_mesh on smooth shapes bounds nothing") {
  for (const Mesh& m : {icosphere(3), torus_grid(32, 16, 1.0, 0.4)}) {
    CurveOptions opt;
    opt.order = 4;
    const CurveResult R = curve_mesh(m, opt);
    CHECK(R.offset_bound.edges == 0);
    CHECK(R.offset_bound.faces == 0);
  }
}

TEST_CASE("offset_bound: what exact surfaces placed is left alone") {
  Fitted s(icosphere(2));
  s.fits = fit_wedges(s.mesh, s.T, s.W, 4, nullptr).fits;  // exact spheres
  s.onto_sphere();
  const int e = interior_edge(s.T);
  s.bulge(e, 0.3, (s.mesh.V.row(s.T.E(e, 0)) + s.mesh.V.row(s.T.E(e, 1))).normalized());
  CHECK(bound_offsets(s.mesh, s.T, s.W, s.fits, nullptr, s.hm).edges == 0);
}
