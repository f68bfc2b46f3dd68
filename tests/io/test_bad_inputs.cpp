// Bad inputs: each gives an InputError naming the file and a location, never a crash or another
// exception type. Includes a small truncation/corruption sweep over valid files of every format.
#include <doctest/doctest.h>

#include "engine/core/error.hpp"
#include "engine/io/read_mesh.hpp"
#include "engine/io/validate_mesh.hpp"
#include "io/io_test_util.hpp"

#include <limits>
#include <random>

using namespace hocurve;
using namespace iotest;

namespace {

/// Reading must throw InputError whose message holds every `parts` entry.
void refused(const std::string& bytes, const std::string& name, std::vector<std::string> parts) {
  CAPTURE(name);
  try {
    read_mesh_bytes(bytes, name);
    FAIL("read succeeded, expected an InputError");
  } catch (const InputError& e) {
    const std::string msg = e.what();
    CAPTURE(msg);
    CHECK(msg.rfind(name, 0) == 0);  // starts with the file name
    for (const auto& p : parts) CHECK(msg.find(p) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("empty, blank and garbage input") {
  refused("", "e.stl", {"empty file"});
  refused(gzip(""), "e.stl.gz", {"empty file"});
  refused("  \n\t\n", "blank.obj", {"white space"});
  std::mt19937 rng(12345);
  std::string garbage(5000, '\0');
  for (auto& c : garbage) c = static_cast<char>(rng());
  refused(garbage, "garbage.bin", {"unknown mesh format"});
  refused(garbage, "garbage.stl", {"binary STL"});  // the name hint makes it a (broken) binary STL
  refused(gzip(garbage).substr(0, 100), "cut.gz", {"gzip"});
  refused("solid x\nendsolid x\n", "nofacets.stl", {"no triangles"});
  CHECK_THROWS_AS(read_mesh_file(tmp_path("does_not_exist.stl")), InputError);
  // A directory read as a file of unbounded size (out of memory, exit 5); a device never ends.
  CHECK_THROWS_WITH_AS(read_mesh_file("."), doctest::Contains("is a directory"), InputError);
  CHECK_THROWS_WITH_AS(read_mesh_file("/dev/zero"), doctest::Contains("is a device"), InputError);
}

TEST_CASE("truncated binary STL names the incomplete facet") {
  const std::string stl = stl_binary(octahedron());
  refused(stl.substr(0, stl.size() - 7), "t.stl", {"truncated binary STL", "declares 8 facets", "facet 7"});
  refused(stl.substr(0, 60), "t.stl", {"truncated binary STL", "84-byte header"});
}

TEST_CASE("NaN and infinite coordinates are located") {
  Mesh m = octahedron();
  m.V(2, 1) = std::numeric_limits<double>::quiet_NaN();  // face 0 corner 1 is vertex 2
  refused(stl_binary(m), "n.stl", {"facet 0", "vertex 1 has a NaN"});
  refused(stl_ascii(m), "n.stl", {"line 5", "facet 0: vertex 1 has a NaN"});
  refused(off_text(m), "n.off", {"vertex 2 has a NaN"});
  m.V(2, 1) = std::numeric_limits<double>::infinity();
  refused(obj_text(m), "n.obj", {"vertex 3 (counting from 1) has an infinite y"});
  Mesh direct = octahedron();
  direct.V(4, 2) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH_AS(validate_mesh(direct), "vertex 4: has a NaN z coordinate", InputError);
}

TEST_CASE("meshes too large or too small for double-precision geometry are refused") {
  for (double scale : {1e31, 1e150, 1e-31, 1e-150}) {
    Mesh m = octahedron();
    m.V *= scale;
    CHECK_THROWS_WITH_AS(validate_mesh(m), doctest::Contains("rescale the mesh"), InputError);
  }
  for (double scale : {1e29, 1e-29}) {
    Mesh m = octahedron();
    m.V *= scale;
    CHECK_NOTHROW(validate_mesh(m));
  }
}

TEST_CASE("out-of-range indices are located") {
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 99\n", "i.obj", {"line 5", "99", "out of range"});
  // 2^32 + 3 wrapped to vertex 3 inside tinyobjloader; a 20-digit index too.
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967299\n", "w.obj", {"line 4", "4294967299", "out of range"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", "w.obj", {"line 4", "out of range"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -99999999999999999999\n", "w.obj", {"line 4", "out of range"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "w.obj", {"line 4", "-4", "out of range"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "w.obj", {"line 4", "x", "not an integer"});
  refused("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "i.off", {"line 6", "face 0", "index 3 out of range"});
  refused("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
          "i.ply", {"face 0", "index -1 out of range"});
  // Found by fuzzing: an index beyond long long (UB when converted), and a fractional one (float lists).
  refused("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3e37\n",
          "i.ply", {"face 0", "index 3e+37 out of range"});
  refused("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n",
          "i.ply", {"face 0", "index 1.5 out of range"});
  Mesh m = octahedron();
  m.F(3, 2) = 6;
  CHECK_THROWS_WITH_AS(validate_mesh(m), "face 3: vertex index 6 out of range [0, 6)", InputError);
}

TEST_CASE("OBJ coordinates that are not numbers are located") {
  // tinyobjloader read each of these as 0: a wrong triangle, exit 0.
  refused("v 0 0 0\nv 1 0 0\nv 0 1 \xff\nf 1 2 3\n", "c.obj", {"line 3", "'?' is not a number"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 abc\nf 1 2 3\n", "c.obj", {"line 3", "'abc' is not a number"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1.5x 0\nf 1 2 3\n", "c.obj", {"line 3", "'1.5x' is not a number"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n", "c.obj", {"line 3", "2 coordinates"});
  refused("v 0 0 0\nv 1 0 0\nv 0 1 1e999\nf 1 2 3\n", "c.obj", {"vertex 3", "infinite"});
}

TEST_CASE("lying counts in PLY, OFF and STL") {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  refused(head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "c.ply", {"line 14: face 0", "unexpected end of file"});
  refused("ply\nformat binary_little_endian 1.0\nelement vertex 3000000000\nproperty float x\nproperty float y\n"
          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + std::string(50, '\0'),
          "c.ply", {"line 3", "declares 3000000000"});
  refused("ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
          "property double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + std::string(70, '\0'),
          "c.ply", {"vertex 2", "unexpected end of binary data"});
  refused("OFF\n10 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "c.off", {"line 2", "declares 10 vertices"});
  refused("OFF\n3 5 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "c.off", {"declares 3 vertices and 5 faces"});
  // Counts that fit the byte budget but not the content.
  refused("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" + std::string(40, ' '), "c.off", {"face 0"});
  refused("OFF\n3 3 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" + std::string(40, '\n'), "c.off",
          {"end of file at face 1 of 3"});
  refused("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "c.off", {"face 0 lists fewer than 4"});
  std::string stl = stl_binary(octahedron());
  const std::uint32_t lie = 1000;
  std::memcpy(stl.data() + 80, &lie, 4);
  refused(stl, "c.stl", {"declares 1000 facets"});
  // Declaring fewer facets than the file holds would drop part of the surface silently.
  const std::uint32_t fewer = 2;
  std::memcpy(stl.data() + 80, &fewer, 4);
  refused(stl, "c.stl", {"declares 2 facets", "hold exactly 8"});
}

TEST_CASE("truncation and corruption sweep: InputError or success, nothing else") {
  const Mesh m = octahedron();
  const std::vector<std::pair<std::string, std::string>> files = {
      {"s.stl", stl_ascii(m)}, {"b.stl", stl_binary(m)}, {"o.obj", obj_text(m)}, {"f.off", off_text(m)},
      {"g.stl.gz", gzip(stl_binary(m))},
      {"p.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},
      {"m.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 0\n1 0 0 0 1 1 0 1 7 0\n$EndEntities\n"
                "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n$Elements\n1 1 1 1\n2 1 2 1\n"
                "1 1 2 3\n$EndElements\n"},
  };
  std::mt19937 rng(7);
  long long ok = 0, refused_count = 0;
  for (const auto& [name, data] : files) {
    CAPTURE(name);
    REQUIRE_NOTHROW(read_mesh_bytes(data, name));
    auto attempt = [&](const std::string& bytes) {
      try {
        ReadResult r = read_mesh_bytes(bytes, name);
        ValidateOptions vo;
        vo.name = name;
        validate_mesh(r.mesh, vo);
        ++ok;
      } catch (const InputError& e) {
        ++refused_count;
        REQUIRE(std::string(e.what()).rfind(name, 0) == 0);
      }
    };
    for (std::size_t cut = 0; cut < data.size(); cut += 1 + data.size() / 150) attempt(data.substr(0, cut));
    for (int k = 0; k < 300; ++k) {
      std::string bad = data;
      for (int j = 0; j < 3; ++j) bad[rng() % bad.size()] = static_cast<char>(rng());
      attempt(bad);
    }
  }
  CHECK(refused_count > 0);
  MESSAGE("sweep: " << ok << " read, " << refused_count << " refused");
}
