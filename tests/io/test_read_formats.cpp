// Round trips: small meshes written here by independent writers, read back by read_mesh_*.
#include <doctest/doctest.h>

#include "engine/core/error.hpp"
#include "engine/io/read_mesh.hpp"
#include "engine/io/weld_vertices.hpp"
#include "io/io_test_util.hpp"

#include <bit>
#include <cmath>
#include <numbers>

using namespace hocurve;
using namespace iotest;

namespace {

/// The faces of `got` are the faces of `want`, vertex by vertex, by position (exact compare).
void check_same_faces(const Mesh& got, const Mesh& want) {
  REQUIRE(got.num_faces() == want.num_faces());
  for (int f = 0; f < want.num_faces(); ++f)
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) REQUIRE(got.V(got.F(f, j), d) == want.V(want.F(f, j), d));
}

/// Independent first-seen re-indexing with std::map: the welded mesh STL reading must give.
Mesh first_seen(const Mesh& m) {
  std::map<std::array<double, 3>, int> seen;
  Mesh out;
  std::vector<std::array<double, 3>> pts;
  out.F.resize(m.num_faces(), 3);
  for (int f = 0; f < m.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      std::array<double, 3> p = {m.V(m.F(f, j), 0), m.V(m.F(f, j), 1), m.V(m.F(f, j), 2)};
      auto [it, fresh] = seen.emplace(p, static_cast<int>(pts.size()));
      if (fresh) pts.push_back(p);
      out.F(f, j) = it->second;
    }
  out.V.resize(static_cast<int>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (int d = 0; d < 3; ++d) out.V(i, d) = pts[i][d];
  return out;
}

}  // namespace

TEST_CASE("STL ascii and binary, plain and gzip: exact weld in first-seen order") {
  const Mesh m = octahedron();
  const Mesh want = first_seen(m);
  struct Case { std::string name, data, format; bool gz; };
  const std::vector<Case> cases = {
      {"a.stl", stl_ascii(m), "stl-ascii", false},
      {"b.stl", stl_binary(m), "stl-binary", false},
      {"c.stl", stl_binary(m, "solid but binary (SolidWorks style header)"), "stl-binary", false},
      {"a.stl.gz", gzip(stl_ascii(m)), "stl-ascii", true},
      {"noname", gzip(stl_binary(m)), "stl-binary", true},
  };
  for (const auto& c : cases) {
    CAPTURE(c.name);
    CHECK(detect_format(c.data, c.name) == c.format);
    const ReadResult r = read_mesh_bytes(c.data, c.name);
    CHECK(r.report.format == c.format);
    CHECK(r.report.gzip == c.gz);
    CHECK(r.report.facets_read == 8);
    CHECK(r.report.welded_vertices == 24 - 6);
    CHECK(r.mesh.V == want.V);
    CHECK(r.mesh.F == want.F);
  }
  // Through a file too.
  write_file(tmp_path("oct.stl.gz"), gzip(stl_binary(m)));
  const ReadResult r = read_mesh_file(tmp_path("oct.stl.gz"));
  CHECK(r.mesh.F == want.F);
  // Without welding every facet keeps its own corners.
  ReadOptions no_weld;
  no_weld.weld = false;
  const ReadResult u = read_mesh_bytes(stl_binary(m), "u.stl", no_weld);
  CHECK(u.mesh.num_vertices() == 24);
  check_same_faces(u.mesh, m);
}

TEST_CASE("Indexed formats that repeat positions are welded too (per-face exports)") {
  // Every face with its own three vertices: unwelded, the octahedron would be 8 open triangles.
  const Mesh m = octahedron();
  Mesh per_face;
  per_face.V.resize(3 * m.num_faces(), 3);
  per_face.F.resize(m.num_faces(), 3);
  for (int f = 0; f < m.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) per_face.V.row(3 * f + j) = m.V.row(m.F(f, j)), per_face.F(f, j) = 3 * f + j;
  const Mesh want = first_seen(m);
  for (const auto& [name, data] : {std::pair<std::string, std::string>{"p.obj", obj_text(per_face)}, {"p.off", off_text(per_face)}}) {
    CAPTURE(name);
    const ReadResult r = read_mesh_bytes(data, name);
    CHECK(r.report.welded_vertices == 24 - 6);
    CHECK(r.mesh.V == want.V);
    CHECK(r.mesh.F == want.F);
    REQUIRE(r.report.warnings.size() == 1);
    CHECK(r.report.warnings[0].find("18 vertices repeat") != std::string::npos);
  }
  // A proper indexed mesh is left as it is, and weld = false keeps the repeats.
  const ReadResult plain = read_mesh_bytes(obj_text(m), "m.obj");
  CHECK(plain.report.welded_vertices == 0);
  CHECK(plain.mesh.V == m.V);
  CHECK(plain.report.warnings.empty());
  ReadOptions no_weld;
  no_weld.weld = false;
  CHECK(read_mesh_bytes(obj_text(per_face), "p.obj", no_weld).mesh.num_vertices() == 24);
}

TEST_CASE("near-duplicate vertices (faces tessellated apart) are welded within 1e-9 of the diagonal") {
  // Every face with its own corners, each copy moved by up to 1e-12 (diagonal 2): a soup that
  // came out flat; moved by 1e-6 it stays a soup unless --weld-tolerance asks for more.
  const Mesh m = octahedron();
  auto soup = [&](double jitter) {
    Mesh s;
    s.V.resize(3 * m.num_faces(), 3);
    s.F.resize(m.num_faces(), 3);
    for (int f = 0; f < m.num_faces(); ++f)
      for (int j = 0; j < 3; ++j) {
        const double d = jitter * (1 + 3 * f + j) / 24.0;  // each copy its own: no exact repeat
        s.V.row(3 * f + j) = m.V.row(m.F(f, j)) + Eigen::RowVector3d(d, -d, 0.5 * d);
        s.F(f, j) = 3 * f + j;
      }
    return s;
  };
  for (const char* name : {"s.obj", "s.stl"}) {
    CAPTURE(name);
    auto text = [&](const Mesh& s) { return std::string(name) == "s.obj" ? obj_text(s) : stl_ascii(s); };
    const ReadResult near = read_mesh_bytes(text(soup(1e-12)), name);
    CHECK(near.mesh.num_vertices() == 6);
    CHECK(near.report.welded_vertices == 18);
    CHECK(near.report.warnings.back().find("of the bounding-box diagonal) of another") != std::string::npos);
    CHECK(read_mesh_bytes(text(soup(1e-6)), name).mesh.num_vertices() == 24);
    ReadOptions wide;
    wide.weld_tolerance = 1e-5;
    CHECK(read_mesh_bytes(text(soup(1e-6)), name, wide).mesh.num_vertices() == 6);
    ReadOptions exact;
    exact.weld_tolerance = 0;
    CHECK(read_mesh_bytes(text(soup(1e-12)), name, exact).mesh.num_vertices() == 24);
  }
}

TEST_CASE("weld_within: chains of close points join the lowest-numbered one") {
  Eigen::MatrixXd V(5, 3);
  V << 0, 0, 0,  //
      1, 0, 0,   //
      1e-10, 0, 0, 2e-10, 0, 0, 1 + 5e-11, 0, 0;
  CHECK(weld_within(V, 1.5e-10) == std::vector<int>{0, 1, 0, 0, 1});
  CHECK(weld_within(V, 0) == std::vector<int>{0, 1, 2, 3, 4});
  // Points on a plane perpendicular to no axis and on the axes' planes: only true neighbours join.
  Eigen::MatrixXd G(2000, 3);
  for (int i = 0; i < 1000; ++i) {
    G.row(i) << i * 1e-3, 0, 0;
    G.row(1000 + i) << i * 1e-3, 0, (i % 2 ? 1e-12 : 1.0);
  }
  const std::vector<int> w = weld_within(G, 1e-9);
  for (int i = 0; i < 2000; ++i) REQUIRE(w[i] == (i >= 1000 && i % 2 ? i - 1000 : i));
}

TEST_CASE("ASCII STL with two solids gives two surface entities") {
  const Mesh m = octahedron();
  const std::string text = stl_ascii(m, "one") + stl_ascii(m, "two");
  const ReadResult r = read_mesh_bytes(text, "two.stl");
  REQUIRE(r.mesh.num_faces() == 16);
  REQUIRE(r.mesh.face_entity.size() == 16);
  for (int f = 0; f < 16; ++f) CHECK(r.mesh.face_entity[f] == (f < 8 ? 1 : 2));
}

TEST_CASE("weld_exact: -0 equals +0, nothing else is merged") {
  const float p[] = {0.f, 1.f, 2.f, -0.f, 1.f, 2.f, std::nextafter(0.f, 1.f), 1.f, 2.f, 0.f, 1.f, 2.f};
  const auto w = weld_exact(p, 4);
  CHECK(w.points.size() == 6);
  CHECK(w.index == std::vector<int>{0, 0, 1, 0});
  // Many points on a grid, each repeated: count and order independent of hashing.
  std::vector<double> g;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 20000; ++i) g.insert(g.end(), {i * 0.1, -i * 0.3, 1.0 / (i + 1)});
  const auto wg = weld_exact(g.data(), g.size() / 3);
  CHECK(wg.points.size() == 3 * 20000);
  for (int i = 0; i < 60000; ++i) REQUIRE(wg.index[i] == i % 20000);
}

TEST_CASE("OBJ: split polygons, negative indices, double precision") {
  const std::string text =
      "# quad and pentagon\nmtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.1234567890123456789 2 0\n"
      "usemtl x\ng quad\nf 1 2 3 4\ng tri\nf -3 -2 -1\nl 1 2\n";
  CHECK(detect_format(text, "") == "obj");
  const ReadResult r = read_mesh_bytes(text, "q.obj");
  CHECK(r.report.format == "obj");
  REQUIRE(r.mesh.num_faces() == 3);
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 2, 3, 4;
  CHECK(r.mesh.F == F);
  CHECK(r.mesh.V(4, 0) == 0.1234567890123456789);  // the double build keeps all digits
  const Mesh m = octahedron();
  const ReadResult o = read_mesh_bytes(gzip(obj_text(m)), "o.obj.gz");
  CHECK(o.report.gzip);
  CHECK(o.mesh.V == m.V);
  CHECK(o.mesh.F == m.F);
}

TEST_CASE("OBJ, OFF and PLY quadrangles are cut along their shorter diagonal, larger polygons fan-split") {
  // Corners 1 and 3 are closer than 0 and 2: the cut joins 1-3; the pentagon fans from corner 0.
  const std::string obj = "v 0 0 0\nv 3 0 0\nv 3.5 1 0\nv 0.5 1 0\nv 1.5 2 0\nf 1 2 3 4\nf 1 2 3 5 4\n";
  const ReadResult r = read_mesh_bytes(obj, "skew.obj");
  REQUIRE(r.mesh.num_faces() == 5);
  Eigen::MatrixXi F(5, 3);
  F << 0, 1, 3, 1, 2, 3, 0, 1, 2, 0, 2, 4, 0, 4, 3;
  CHECK(r.mesh.F == F);
  // The PLY lists its face before its vertices: the cut still uses their positions.
  const std::vector<std::pair<std::string, std::string>> quads = {
      {"skew.off", "OFF\n4 1 0\n0 0 0\n3 0 0\n3.5 1 0\n0.5 1 0\n4 0 1 2 3\n"},
      {"late_vertices.ply",
       "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 4\n"
       "property double x\nproperty double y\nproperty double z\nend_header\n4 0 1 2 3\n"
       "0 0 0\n3 0 0\n3.5 1 0\n0.5 1 0\n"}};
  for (const auto& [name, text] : quads) {
    CAPTURE(name);
    const ReadResult o = read_mesh_bytes(text, name);
    REQUIRE(o.mesh.num_faces() == 2);
    CHECK(o.mesh.F.row(0) == Eigen::RowVector3i(0, 1, 3));
    CHECK(o.mesh.F.row(1) == Eigen::RowVector3i(1, 2, 3));
  }
}

TEST_CASE("OFF: comments, counts on the header line, quads, colours") {
  const Mesh m = octahedron();
  const ReadResult r = read_mesh_bytes(off_text(m), "m.off");
  CHECK(r.report.format == "off");
  CHECK(r.mesh.V == m.V);
  CHECK(r.mesh.F == m.F);
  const std::string quad = "OFF 4 1 0\n0 0 0\n1 0 0 255 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 0.5 0.5 0.5\n";
  const ReadResult q = read_mesh_bytes(quad, "q.off");
  REQUIRE(q.mesh.num_faces() == 2);
  CHECK(q.mesh.F.row(1) == Eigen::RowVector3i(0, 2, 3));
}

namespace {

template <class T>
void put(std::string& s, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

/// PLY with extra properties and elements around the ones we need; vertex coordinates as `vt`.
std::string ply(const Mesh& m, const std::string& format, bool double_xyz, const std::string& list_prop) {
  std::ostringstream h;
  h << "ply\nformat " << format << " 1.0\ncomment made by the test\n"
    << "element vertex " << m.num_vertices() << "\n"
    << "property uchar red\n"
    << (double_xyz ? "property double x\nproperty double y\nproperty double z\n"
                   : "property float x\nproperty float y\nproperty float z\n")
    << "property list uchar int extra_list\n"
    << "element face " << m.num_faces() << "\n"
    << "property short flags\nproperty list " << list_prop << "\n"
    << "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  std::string s = h.str();
  const bool big = format == "binary_big_endian";
  if (format == "ascii") {
    std::ostringstream d;
    for (int v = 0; v < m.num_vertices(); ++v)
      d << "7 " << num(m.V(v, 0)) << " " << num(m.V(v, 1)) << " " << num(m.V(v, 2)) << " 2 5 6\n";
    for (int f = 0; f < m.num_faces(); ++f) d << "-1 3 " << m.F(f, 0) << " " << m.F(f, 1) << " " << m.F(f, 2) << "\n";
    d << "0 1\n";
    return s + d.str();
  }
  for (int v = 0; v < m.num_vertices(); ++v) {
    put<std::uint8_t>(s, 7, big);
    for (int d = 0; d < 3; ++d)
      if (double_xyz) put<double>(s, m.V(v, d), big); else put<float>(s, static_cast<float>(m.V(v, d)), big);
    put<std::uint8_t>(s, 2, big);
    put<std::int32_t>(s, 5, big);
    put<std::int32_t>(s, 6, big);
  }
  const bool u8count = list_prop.rfind("uchar", 0) == 0;
  for (int f = 0; f < m.num_faces(); ++f) {
    put<std::int16_t>(s, -1, big);
    if (u8count) put<std::uint8_t>(s, 3, big); else put<std::int32_t>(s, 3, big);
    for (int j = 0; j < 3; ++j)
      if (list_prop.find("uint ") != std::string::npos) put<std::uint32_t>(s, m.F(f, j), big);
      else put<std::int32_t>(s, m.F(f, j), big);
  }
  put<std::int32_t>(s, 0, big);
  put<std::int32_t>(s, 1, big);
  return s;
}

}  // namespace

TEST_CASE("PLY ascii, binary little and big endian, float/double, both index list names") {
  const Mesh m = octahedron();
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"})
    for (const bool dbl : {false, true})
      for (const std::string list : {"uchar int vertex_indices", "int uint vertex_index"})
        for (const bool gz : {false, true}) {
          CAPTURE(format);
          CAPTURE(dbl);
          CAPTURE(list);
          CAPTURE(gz);
          const std::string data = ply(m, format, dbl, list);
          const ReadResult r = read_mesh_bytes(gz ? gzip(data) : data, "m.ply");
          CHECK(r.report.format == (format == "ascii" ? "ply-ascii" : "ply-binary"));
          CHECK(r.report.gzip == gz);
          CHECK(r.mesh.V == m.V);
          CHECK(r.mesh.F == m.F);
        }
}

TEST_CASE("detect_format on content, name only as a hint") {
  const Mesh m = octahedron();
  CHECK(detect_format(stl_ascii(m), "x.obj") == "stl-ascii");
  CHECK(detect_format(off_text(m), "x.stl") == "off");
  CHECK(detect_format(obj_text(m), "x.ply") == "obj");
  CHECK(detect_format("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n", "") == "msh4");
  CHECK(detect_format("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n", "") == "msh2");
  CHECK(detect_format(ply(m, "binary_little_endian", false, "uchar int vertex_indices"), "") == "ply-binary");
  CHECK(detect_format("hello world, this is not a mesh\n", "x.txt") == "");
  CHECK(detect_format(gzip("just some text\n"), "x.gz") == "");
  // Binary STL with trailing bytes is still found by its header count.
  CHECK(detect_format(stl_binary(m) + "trailing text", "noext") == "stl-binary");
}

TEST_CASE("an n-gon of any size gives n - 2 triangles, and the faces after it keep their corners") {
  // A circle of n corners, then one triangle over vertices (n, n+1, n+2) of its own. tinyobjloader
  // counted corners in 8 bits: a 1000-gon gave (1000 - 2) mod 256 = 230 triangles.
  for (const int n : {3, 4, 5, 255, 256, 257, 258, 1000, 65537, 100000}) {
    CAPTURE(n);
    std::string v, obj_v, obj_face = "f", off_face = std::to_string(n), ply_face = std::to_string(n);
    std::string ply_bin_face;
    put<std::uint32_t>(ply_bin_face, static_cast<std::uint32_t>(n), false);
    for (int c = 0; c < n; ++c) {
      const double a = 2 * std::numbers::pi * c / n;
      v += num(std::cos(a)) + " " + num(std::sin(a)) + " 0\n";
      obj_v += "v " + num(std::cos(a)) + " " + num(std::sin(a)) + " 0\n";
      obj_face += " " + std::to_string(c + 1);
      off_face += " " + std::to_string(c);
      ply_face += " " + std::to_string(c);
      put<std::int32_t>(ply_bin_face, c, false);
    }
    v += "5 0 1\n6 0 1\n5 1 1\n";
    obj_v += "v 5 0 1\nv 6 0 1\nv 5 1 1\n";
    const int nv = n + 3;
    std::string ply_bin_tri;
    put<std::uint32_t>(ply_bin_tri, 3, false);
    for (int c = n; c < nv; ++c) put<std::int32_t>(ply_bin_tri, c, false);
    std::string ply_bin_v;
    for (int c = 0; c < nv; ++c) {
      const double a = 2 * std::numbers::pi * c / n;
      const double p[3] = {c < n ? std::cos(a) : 5.0 + (c == n + 1), c < n ? std::sin(a) : double(c == n + 2), c < n ? 0.0 : 1.0};
      for (double x : p) put<double>(ply_bin_v, x, false);
    }
    const std::string ply_head = "element vertex " + std::to_string(nv) + "\nproperty double x\nproperty double y\n"
                                 "property double z\nelement face 2\nproperty list uint int vertex_indices\nend_header\n";
    const std::vector<std::pair<std::string, std::string>> files = {
        {"ngon.obj", obj_v + obj_face + "\nf " + std::to_string(n + 1) + " " + std::to_string(n + 2) + " -1\n"},
        {"ngon.off", "OFF\n" + std::to_string(nv) + " 2 0\n" + v + off_face + "\n3 " + std::to_string(n) + " " +
                         std::to_string(n + 1) + " " + std::to_string(n + 2) + "\n"},
        {"ngon.ply", "ply\nformat ascii 1.0\n" + ply_head + v + ply_face + "\n3 " + std::to_string(n) + " " +
                         std::to_string(n + 1) + " " + std::to_string(n + 2) + "\n"},
        {"ngon_bin.ply", "ply\nformat binary_little_endian 1.0\n" + ply_head + ply_bin_v + ply_bin_face + ply_bin_tri},
    };
    for (const auto& [name, data] : files) {
      CAPTURE(name);
      const ReadResult r = read_mesh_bytes(data, name);
      REQUIRE(r.mesh.num_faces() == n - 2 + 1);
      REQUIRE(r.mesh.num_vertices() == nv);
      for (int f = 0; f < n - 2; ++f)
        REQUIRE(r.mesh.F.row(f).maxCoeff() < n);
      CHECK(r.mesh.F.row(n - 2) == Eigen::RowVector3i(n, n + 1, n + 2));
    }
  }
  // Beyond what any reader accepts: refused, not truncated.
  CHECK_THROWS_WITH_AS(read_mesh_bytes("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2000000 0 1 2\n", "big.off"),
                       doctest::Contains("bad corner count"), InputError);
}

TEST_CASE("OBJ starting with group and object lines is detected as OBJ") {
  for (const std::string head : {"g\n", "o\n", "g part\n", "o body\ng\n", "# c\ng a b\r\no x\r\n", "s off\ng g1\n"}) {
    CAPTURE(head);
    const std::string text = head + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    CHECK(detect_format(text, "") == "obj");
    CHECK(read_mesh_bytes(text, "x").mesh.num_faces() == 1);
  }
  // A long header (once more than 2000 lines were needed to see the first "v") in the sniffed 64 KiB.
  std::string header;
  for (int k = 0; k < 3000; ++k) header += k % 2 ? "# exported\n" : "g\n";
  CHECK(detect_format(header + "v 0 0 0\n", "") == "obj");
}

TEST_CASE("the near-weld tolerance comes from the vertices faces use, not from unreferenced far ones") {
  // Unreferenced vertices at +-1e30 made the tolerance 2e21: every used vertex merged into one.
  const Mesh m = octahedron();
  const std::string text = obj_text(m) + "v 1e30 0 0\nv -1e30 5 5\nv 1e308 -1e308 0\n";
  const ReadResult r = read_mesh_bytes(text, "far.obj");
  CHECK(r.report.welded_vertices == 0);
  CHECK(r.mesh.V.topRows(6) == m.V);
  CHECK(r.mesh.F == m.F);
}
