// Uniformity statistics and verdict, on exact small cases and on the shared test meshes
// (compared with the independently computed MANIFEST.tsv figures).
#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/curving/uniformity.hpp"
#include "engine/io/read_mesh.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace hocurve;

namespace {

Uniformity check(const Mesh& m, const UniformityOptions& opt = {}) {
  return check_uniformity(m, build_topology(m.F, m.num_vertices()), opt);
}

Mesh triangle(Eigen::Vector3d a, Eigen::Vector3d b, Eigen::Vector3d c) {
  Mesh m;
  m.V.resize(3, 3);
  m.V.row(0) = a.transpose(), m.V.row(1) = b.transpose(), m.V.row(2) = c.transpose();
  m.F.resize(1, 3);
  m.F << 0, 1, 2;
  return m;
}

}  // namespace

TEST_CASE("spread_of: exact order statistics") {
  std::vector<double> x;
  for (int i = 100; i >= 1; --i) x.push_back(i);
  const Spread s = spread_of(x);
  CHECK(s.min == 1);
  CHECK(s.max == 100);
  CHECK(s.mean == doctest::Approx(50.5));
  CHECK(s.p1 == doctest::Approx(1.99));   // position 0.99 between 1 and 2
  CHECK(s.p99 == doctest::Approx(99.01));
  CHECK(s.cv == doctest::Approx(std::sqrt((100.0 * 100.0 - 1) / 12.0) / 50.5));
  CHECK(s.ratio_p99_p1() == doctest::Approx(99.01 / 1.99));
  const Spread e = spread_of({});
  CHECK(e.max == 0);
}

TEST_CASE("aspect of known triangles") {
  // Equilateral: longest edge / altitude = 2/sqrt(3).
  Uniformity u = check(triangle({0, 0, 0}, {1, 0, 0}, {0.5, std::sqrt(3.0) / 2, 0}));
  CHECK(u.aspect.max == doctest::Approx(2 / std::sqrt(3.0)));
  CHECK(u.aspect_normalized.max == doctest::Approx(1.0));
  CHECK(u.area.max == doctest::Approx(std::sqrt(3.0) / 4));
  CHECK(u.edge_length.cv == doctest::Approx(0.0));
  // Right isosceles with unit legs: sqrt(2) / (1/sqrt(2)) = 2.
  u = check(triangle({0, 0, 0}, {1, 0, 0}, {0, 1, 0}));
  CHECK(u.aspect.max == doctest::Approx(2.0));
  // inradius (2 - sqrt 2)/2: sqrt(2) / (sqrt(3) (2 - sqrt(2))).
  CHECK(u.aspect_normalized.max == doctest::Approx(std::sqrt(2.0) / (std::sqrt(3.0) * (2 - std::sqrt(2.0)))));
  // A sliver 10 long and 0.5 high: 10 / 0.5 = 20 > 10, a needle.
  u = check(triangle({0, 0, 0}, {10, 0, 0}, {3, 0.5, 0}));
  CHECK(u.aspect.max == doctest::Approx(20.0));
  CHECK(u.needle_share == 1.0);
  CHECK_FALSE(u.uniform);
  CHECK(u.reason.find("needle") != std::string::npos);
  // Zero area: counted as a needle and as degenerate, kept out of the aspect spread.
  u = check(triangle({0, 0, 0}, {1, 0, 0}, {2, 0, 0}));
  CHECK(u.degenerate_faces == 1);
  CHECK(u.needle_share == 1.0);
  CHECK(u.needle_share_normalized == 1.0);
}

TEST_CASE("synthetic meshes: structured spheres are uniform, CAD strips are not") {
  Uniformity u = check(icosphere(3));
  CHECK(u.uniform);
  CHECK(u.reason.empty());
  CHECK(u.edge_length.ratio_p99_p1() < 1.5);
  CHECK(u.needle_share == 0);
  CHECK(u.area.min > 0);

  u = check(capped_cylinder_cad(32, 1.0, 10.0));
  CHECK_FALSE(u.uniform);
  // Side strips 10 x 0.196: aspect ~ 51; they are half of the faces.
  CHECK(u.needle_share == doctest::Approx(0.5));
  const double chord = 2 * std::sin(std::numbers::pi / 32);
  CHECK(u.aspect.max == doctest::Approx((100 + chord * chord) / (10 * chord)));
  CHECK(u.edge_length.ratio_p99_p1() > 8);
  CHECK(u.reason.find("edge length") != std::string::npos);

  // Thresholds are honoured.
  UniformityOptions loose;
  loose.max_edge_ratio = 1e3;
  loose.max_needle_share = 0.6;
  CHECK(check(capped_cylinder_cad(32, 1.0, 10.0), loose).uniform);
}

namespace {
struct ManifestRow {
  double edge_ratio = 0, needles = 0;
};

std::map<std::string, ManifestRow> read_manifest(const std::string& path) {
  std::map<std::string, ManifestRow> rows;
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string cell;
    while (std::getline(ss, cell, '\t')) out.push_back(cell);
    return out;
  };
  if (!std::getline(in, line)) return rows;
  header = split(line);
  int ci = -1, cn = -1;
  for (size_t i = 0; i < header.size(); ++i) {
    if (header[i] == "edge_ratio_p99_p1") ci = static_cast<int>(i);
    if (header[i] == "frac_aspect_gt10") cn = static_cast<int>(i);
  }
  while (std::getline(in, line)) {
    const auto c = split(line);
    if (ci < 0 || cn < 0 || static_cast<int>(c.size()) <= std::max(ci, cn)) continue;
    try {
      rows[c[0]] = {std::stod(c[ci]), std::stod(c[cn])};
    } catch (...) {
    }
  }
  return rows;
}
}  // namespace

TEST_CASE("shared meshes: figures agree with MANIFEST.tsv and the verdicts are right") {
  const std::string dir = std::string(HOCURVE_SHARED_DIR) + "/meshes/";
  const auto manifest = read_manifest(dir + "MANIFEST.tsv");
  REQUIRE(!manifest.empty());
  const std::map<std::string, bool> verdict = {
      {"armadillo.obj", true},         {"bunny_closed.obj", true}, {"skull_lowres.obj", true},
      {"torus.obj", true},             {"lever_solidedge.stl", false}, {"hinge_netgen.stl", false},
      {"ktoolcav.stl", false},         {"t13_data.stl", false}};
  for (const auto& [name, uniform] : verdict) {
    CAPTURE(name);
    REQUIRE(manifest.count(name));
    const ManifestRow& row = manifest.at(name);
    const Mesh m = read_mesh_file(dir + name).mesh;
    const Uniformity u = check(m);
    const double ratio = u.edge_length.ratio_p99_p1();
    std::printf("%-22s edge p99/p1 %8.4g (manifest %8.4g)  needles %.4g, normalised %.4g (manifest %.4g)  %s %s\n",
                name.c_str(), ratio, row.edge_ratio, u.needle_share, u.needle_share_normalized, row.needles,
                u.uniform ? "uniform" : "non-uniform", u.reason.c_str());
    // The manifest rounds to 3 significant digits; its aspect is the normalised one.
    CHECK(ratio == doctest::Approx(row.edge_ratio).epsilon(0.03));
    CHECK(u.needle_share_normalized == doctest::Approx(row.needles).epsilon(0.03).scale(1e-4));
    // lmax / altitude = normalised * 2 sqrt(3) lmax / perimeter >= normalised * 2/sqrt(3):
    // the altitude measure flags at least as many needles.
    CHECK(u.needle_share >= u.needle_share_normalized);
    CHECK(u.uniform == uniform);
  }
}
