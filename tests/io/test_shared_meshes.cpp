// Every mesh in shared/meshes reads with the triangle count of MANIFEST.tsv (an independent record
// made with other tools), and validates with the closedness and component counts it lists.
#include <doctest/doctest.h>

#include "engine/core/error.hpp"
#include "engine/io/read_mesh.hpp"
#include "engine/io/validate_mesh.hpp"

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace hocurve;

namespace {

struct ManifestRow {
  std::string name;
  long long triangles = -1;
  std::string closed;
  int components = -1;
};

std::vector<ManifestRow> read_manifest() {
  std::ifstream in(std::string(HOCURVE_SHARED_DIR) + "/meshes/MANIFEST.tsv");
  REQUIRE(in.good());
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  {
    std::istringstream hs(line);
    std::string h;
    while (std::getline(hs, h, '\t')) head.push_back(h);
  }
  auto col = [&](const std::string& h) {
    for (std::size_t i = 0; i < head.size(); ++i)
      if (head[i] == h) return static_cast<int>(i);
    FAIL("MANIFEST has no column " << h);
    return -1;
  };
  const int c_name = col("name"), c_tri = col("triangles"), c_closed = col("closed"), c_comp = col("components");
  std::vector<ManifestRow> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream ls(line);
    std::string x;
    while (std::getline(ls, x, '\t')) f.push_back(x);
    if (static_cast<int>(f.size()) <= c_comp) continue;
    ManifestRow r;
    r.name = f[c_name];
    try { r.triangles = std::stoll(f[c_tri]); } catch (...) { continue; }  // CAD rows: "n/a"
    r.closed = f[c_closed];
    try { r.components = std::stoi(f[c_comp]); } catch (...) {}
    rows.push_back(r);
  }
  return rows;
}

}  // namespace

TEST_CASE("every shared mesh reads with the MANIFEST triangle count") {
  const auto rows = read_manifest();
  CHECK(rows.size() >= 16);
  for (const auto& row : rows) {
    CAPTURE(row.name);
    const std::string path = std::string(HOCURVE_SHARED_DIR) + "/meshes/" + row.name;
    ReadResult rr;
    REQUIRE_NOTHROW(rr = read_mesh_file(path));
    CHECK(rr.report.facets_read == row.triangles);
    CHECK(rr.mesh.num_faces() == row.triangles);
    ValidateOptions vo;
    vo.name = path;
    ValidateReport vr;
    REQUIRE_NOTHROW(vr = validate_mesh(rr.mesh, vo));
    CHECK(vr.degenerate_faces == 0);
    CHECK(vr.duplicate_faces == 0);
    if (row.closed == "True") CHECK(vr.boundary_edges == 0);
    if (row.closed == "False") CHECK(vr.boundary_edges > 0);
    if (row.components > 0) CHECK(vr.components == row.components);
    CHECK(vr.non_orientable_components == 0);
    MESSAGE(row.name << ": " << rr.report.format << " V=" << rr.mesh.num_vertices() << " welded="
                     << rr.report.welded_vertices << " flipped=" << vr.flipped_faces << " nm_e="
                     << vr.nonmanifold_edges << " nm_v=" << vr.nonmanifold_vertices << " zero_area="
                     << vr.zero_area_faces << " warnings=" << rr.report.warnings.size() + vr.warnings.size());
  }
}

TEST_CASE("ktoolcav.stl: declared facets read, trailing text reported with its byte count") {
  const std::string path = std::string(HOCURVE_SHARED_DIR) + "/meshes/ktoolcav.stl";
  const ReadResult rr = read_mesh_file(path);
  CHECK(rr.report.format == "stl-binary");
  CHECK(rr.mesh.num_faces() == 4090);
  REQUIRE(rr.report.warnings.size() == 1);
  CHECK(rr.report.warnings[0].find("723 bytes after the 4090 facets") != std::string::npos);
}

TEST_CASE("king_ascii.stl.gz is detected as gzip ASCII STL") {
  const std::string path = std::string(HOCURVE_SHARED_DIR) + "/meshes/king_ascii.stl.gz";
  const ReadResult rr = read_mesh_file(path);
  CHECK(rr.report.gzip);
  CHECK(rr.report.format == "stl-ascii");
  std::ifstream in(path, std::ios::binary);
  std::string head(4096, '\0');
  in.read(head.data(), head.size());
  head.resize(in.gcount());
  CHECK(detect_format(head, "no-hint") == "stl-ascii");  // looks through gzip, no name needed
}
