// validate_mesh on hand-made meshes whose defects are known by construction.
#include <doctest/doctest.h>

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/io/validate_mesh.hpp"
#include "io/io_test_util.hpp"

#include <Eigen/Geometry>

using namespace hocurve;

namespace {

double signed_volume(const Mesh& m) {
  double v = 0;
  for (int f = 0; f < m.num_faces(); ++f)
    v += Eigen::Vector3d(m.V.row(m.F(f, 0))).dot(Eigen::Vector3d(m.V.row(m.F(f, 1))).cross(Eigen::Vector3d(m.V.row(m.F(f, 2)))));
  return v / 6;
}

/// Every manifold edge is walked once in each direction.
bool consistent(const Mesh& m) {
  const Topology T = build_topology(m.F, m.num_vertices());
  for (int e = 0; e < T.num_edges(); ++e) {
    if (T.edge_faces[e].size() != 2) continue;
    int forward = 0;
    for (int f : T.edge_faces[e])
      for (int j = 0; j < 3; ++j)
        if (m.F(f, j) == T.E(e, 0) && m.F(f, (j + 1) % 3) == T.E(e, 1)) ++forward;
    if (forward != 1) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("clean closed mesh: nothing to report") {
  Mesh m = iotest::octahedron();
  const Mesh before = m;
  const ValidateReport r = validate_mesh(m);
  CHECK(r.warnings.empty());
  CHECK(r.components == 1);
  CHECK(r.boundary_edges == 0);
  CHECK(m.F == before.F);
  CHECK(m.V == before.V);
}

TEST_CASE("inconsistent orientation: minority flipped, inside-out closed mesh turned outward") {
  Mesh m = iotest::octahedron();
  const double vol = signed_volume(m);
  REQUIRE(vol > 0);
  for (int f : {1, 4, 6}) std::swap(m.F(f, 1), m.F(f, 2));
  REQUIRE(!consistent(m));
  ValidateReport r = validate_mesh(m);
  CHECK(r.flipped_faces == 3);
  CHECK(consistent(m));
  CHECK(signed_volume(m) == doctest::Approx(vol));
  CHECK(m.F == iotest::octahedron().F);

  Mesh inv = iotest::octahedron();
  for (int f = 0; f < 8; ++f) std::swap(inv.F(f, 1), inv.F(f, 2));
  r = validate_mesh(inv);
  CHECK(r.flipped_faces == 8);
  CHECK(r.outward_flipped_components == 1);
  CHECK(signed_volume(inv) == doctest::Approx(vol));
  ValidateOptions keep;
  keep.orient_outward = false;
  Mesh inv2 = iotest::octahedron();
  for (int f = 0; f < 8; ++f) std::swap(inv2.F(f, 1), inv2.F(f, 2));
  CHECK(validate_mesh(inv2, keep).flipped_faces == 0);
}

TEST_CASE("Moebius strip is reported non-orientable and left as read") {
  // A strip of 2n triangles between two rows, closed with a half twist.
  const int n = 8;
  Mesh m;
  m.V.resize(2 * n, 3);
  for (int i = 0; i < n; ++i) {
    const double t = 2 * M_PI * i / n, w = 0.3 * std::cos(t / 2), h = 0.3 * std::sin(t / 2);
    m.V.row(2 * i) << (1 + w) * std::cos(t), (1 + w) * std::sin(t), h;
    m.V.row(2 * i + 1) << (1 - w) * std::cos(t), (1 - w) * std::sin(t), -h;
  }
  m.F.resize(2 * n, 3);
  for (int i = 0; i < n; ++i) {
    const int a = 2 * i, b = 2 * i + 1;
    int c = 2 * (i + 1), d = 2 * (i + 1) + 1;
    if (i == n - 1) c = 1, d = 0;  // the twist
    m.F.row(2 * i) << a, b, c;
    m.F.row(2 * i + 1) << b, d, c;
  }
  const Mesh before = m;
  const ValidateReport r = validate_mesh(m);
  CHECK(r.non_orientable_components == 1);
  CHECK(r.boundary_edges == 2 * n);
  CHECK(m.F == before.F);
}

TEST_CASE("degenerate, duplicate and zero-area faces, unused vertices") {
  Mesh m = iotest::octahedron();
  m.V.conservativeResize(8, 3);
  m.V.row(6) << 9, 9, 9;                       // unused
  m.V.row(7) = 0.5 * (m.V.row(0) + m.V.row(1));  // collinear with 0 and 1
  m.F.conservativeResize(12, 3);
  m.F.row(8) << 0, 0, 2;   // degenerate
  m.F.row(9) << 2, 4, 0;   // duplicate of face 0 (rotated)
  m.F.row(10) << 4, 2, 0;  // duplicate of face 0 (reversed)
  m.F.row(11) << 0, 7, 1;  // zero area (a flap on edge 0-1, kept here: see the flap test below)
  ValidateOptions keep_flaps;
  keep_flaps.drop_zero_area_flaps = false;
  const ValidateReport r = validate_mesh(m, keep_flaps);
  CHECK(r.degenerate_faces == 1);
  CHECK(r.duplicate_faces == 2);
  CHECK(r.zero_area_faces == 1);
  CHECK(r.unused_vertices == 1);
  CHECK(m.num_faces() == 9);
  CHECK(m.num_vertices() == 7);
  CHECK(m.V.row(6) == Eigen::RowVector3d(0.5 * (1.5 - 1.25), 0.25, 0));
}

TEST_CASE("a zero-area cap closing a T-junction is flipped into its neighbour, same surface") {
  // Unit square: face (0, 1, 2) on one side of the diagonal 0-2, the other side split at the
  // diagonal's midpoint 4 and the T-junction closed by the zero-area cap (0, 2, 4).
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 0.5, 0;
  m.F.resize(4, 3);
  m.F << 0, 1, 2, 0, 2, 4, 0, 4, 3, 4, 2, 3;
  const ValidateReport r = validate_mesh(m);
  CHECK(r.zero_area_faces == 1);
  CHECK(r.zero_area_caps_flipped == 1);
  CHECK(r.flipped_faces == 0);  // the new faces keep the orientation
  CHECK(r.boundary_edges == 4);
  REQUIRE(m.num_faces() == 4);
  double area = 0;
  for (int f = 0; f < 4; ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double z = 0.5 * (b - a).cross(c - a).z();
    CHECK(z > 0.1);  // no zero-area face left, all facing +z
    area += z;
  }
  CHECK(area == doctest::Approx(1.0));
  // With the flip turned off the mesh keeps its cap.
  Mesh keep = m;
  keep.F << 0, 1, 2, 0, 2, 4, 0, 4, 3, 4, 2, 3;
  ValidateOptions no;
  no.flip_zero_area_caps = false;
  CHECK(validate_mesh(keep, no).zero_area_caps_flipped == 0);
  CHECK(keep.F(1, 2) == 4);
}

TEST_CASE("zero-area flaps and lone collinear triangles are removed, all-collinear input is refused") {
  Mesh m = iotest::octahedron();
  const int nv = m.num_vertices(), nf = m.num_faces();
  m.V.conservativeResize(nv + 4, 3);
  m.V.row(nv) = 0.5 * (m.V.row(m.F(0, 0)) + m.V.row(m.F(0, 1)));  // flap on face 0's first edge
  m.V.row(nv + 1) << 5, 0, 0;
  m.V.row(nv + 2) << 6, 0, 0;
  m.V.row(nv + 3) << 7, 0, 0;  // a lone collinear triangle far away
  m.F.conservativeResize(nf + 2, 3);
  m.F.row(nf) << m.F(0, 0), m.F(0, 1), nv;
  m.F.row(nf + 1) << nv + 1, nv + 2, nv + 3;
  const ValidateReport r = validate_mesh(m);
  CHECK(r.zero_area_faces == 2);
  CHECK(r.zero_area_flaps_removed == 2);
  CHECK(r.nonmanifold_edges == 0);
  CHECK(r.boundary_edges == 0);
  CHECK(m.num_faces() == nf);
  CHECK(m.num_vertices() == nv);
  Mesh line;
  line.V.resize(4, 3);
  line.V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0;
  line.F.resize(3, 3);
  line.F << 0, 1, 2, 1, 2, 3, 0, 1, 3;
  CHECK_THROWS_WITH_AS(validate_mesh(line), doctest::Contains("every face has zero area"), InputError);
}

TEST_CASE("non-manifold edge, pinched vertex, open boundary, components") {
  // Three triangles on one edge (0,1).
  Mesh fin;
  fin.V.resize(5, 3);
  fin.V << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0, 0.5, 0, 1;
  fin.F.resize(3, 3);
  fin.F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  ValidateReport r = validate_mesh(fin);
  CHECK(r.nonmanifold_edges == 1);
  CHECK(r.boundary_edges == 6);
  CHECK(r.components == 1);

  // Two octahedra touching at one vertex: one pinched vertex, two edge-components.
  Mesh a = iotest::octahedron();
  Mesh two;
  two.V.resize(11, 3);
  two.V.topRows(6) = a.V;
  const Eigen::RowVector3d shift = a.V.row(0) - a.V.row(1);  // b's vertex 1 lands on a's vertex 0
  int map[6] = {6, 0, 7, 8, 9, 10};
  for (int v = 0; v < 6; ++v)
    if (v != 1) two.V.row(map[v]) = a.V.row(v) + shift;
  two.F.resize(16, 3);
  two.F.topRows(8) = a.F;
  for (int f = 0; f < 8; ++f)
    for (int j = 0; j < 3; ++j) two.F(8 + f, j) = map[a.F(f, j)];
  r = validate_mesh(two);
  CHECK(r.nonmanifold_vertices == 1);
  CHECK(r.nonmanifold_edges == 0);
  CHECK(r.components == 2);
  CHECK(r.flipped_faces == 0);
}

TEST_CASE("no triangles is fatal") {
  Mesh m;
  m.V.resize(3, 3);
  m.V.setZero();
  CHECK_THROWS_AS(validate_mesh(m), InputError);
}
