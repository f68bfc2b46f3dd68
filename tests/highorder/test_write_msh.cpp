// .msh writer: every format read back by the Gmsh SDK (and by meshio when available), plus the
// straight high-order mesh construction it writes.
#include "engine/highorder/write_msh.hpp"

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/lagrange.hpp"

#include <doctest/doctest.h>
#include <gmsh.h>
#include "gmsh_session.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

using namespace hocurve;
namespace fs = std::filesystem;

namespace {


// Octahedron split into 4 triangles per face (32 faces), three entities and two groups.
Mesh test_mesh() {
  Mesh m;
  const double P[6][3] = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const int T[8][3] = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {1, 0, 5}, {2, 1, 5}, {3, 2, 5}, {0, 3, 5}};
  std::vector<Eigen::RowVector3d> V;
  for (auto& p : P) V.emplace_back(p[0], p[1], p[2]);
  std::map<std::pair<int, int>, int> mid;
  auto midpoint = [&](int a, int b) {
    auto key = std::minmax(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    V.push_back(0.5 * (V[a] + V[b]));
    return mid[key] = static_cast<int>(V.size()) - 1;
  };
  std::vector<Eigen::RowVector3i> F;
  std::vector<int> ent;
  for (int t = 0; t < 8; ++t) {
    const int a = T[t][0], b = T[t][1], c = T[t][2];
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    for (Eigen::RowVector3i f : {Eigen::RowVector3i(a, ab, ca), Eigen::RowVector3i(ab, b, bc),
                                 Eigen::RowVector3i(ca, bc, c), Eigen::RowVector3i(ab, bc, ca)}) {
      F.push_back(f);
      ent.push_back(t < 4 ? 1 : (t == 7 ? 5 : 2));  // top = 1, bottom = 2 and 5
    }
  }
  m.V.resize(V.size(), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(i) = V[i].normalized();
  m.F.resize(F.size(), 3);
  m.face_entity.resize(F.size());
  for (size_t f = 0; f < F.size(); ++f) m.F.row(f) = F[f], m.face_entity[f] = ent[f];
  m.physicals = {{7, "top", {1}}, {9, "bottom", {2, 5}}};
  return m;
}

// Curved high-order mesh: straight nodes pushed onto the unit sphere (non-trivial doubles).
HighOrderMesh curved(const Mesh& m, int p, NodeDistribution d = NodeDistribution::Equispaced) {
  HighOrderMesh hm = make_straight_high_order(m, build_topology(m.F, m.num_vertices()), p, d);
  hm.edge_nodes.rowwise().normalize();
  hm.face_nodes.rowwise().normalize();
  return hm;
}

fs::path out_dir() {
  fs::path d = fs::path(HOCURVE_BINARY_DIR) / "test-output" / "msh";
  fs::create_directories(d);
  return d;
}

struct Format {
  const char* name;
  MshOptions opt;
};

std::vector<Format> formats() {
  using V = MshOptions::Version;
  return {{"v41_ascii", {V::V41, false}}, {"v41_binary", {V::V41, true}},
          {"v22_ascii", {V::V22, false}}, {"v22_binary", {V::V22, true}}};
}

// Reads path with Gmsh and compares everything with hm.
void check_with_gmsh(const HighOrderMesh& hm, const std::string& path) {
  gmsh::open(path);
  const int p = hm.order, n = triangle_node_count(p);
  const Eigen::MatrixXd X = all_nodes(hm);

  std::vector<std::size_t> tags;
  std::vector<double> coord, par;
  gmsh::model::mesh::getNodes(tags, coord, par, -1, -1, true, false);
  REQUIRE(tags.size() == static_cast<size_t>(X.rows()));
  double err = 0;
  for (size_t i = 0; i < tags.size(); ++i) {
    REQUIRE(tags[i] >= 1);
    REQUIRE(tags[i] <= static_cast<size_t>(X.rows()));
    for (int d = 0; d < 3; ++d) err = std::max(err, std::abs(coord[3 * i + d] - X(tags[i] - 1, d)));
  }
  CHECK(err == 0.0);  // shortest round-trip text and binary both restore every bit

  // Element connectivity, per element tag (= face + 1).
  std::vector<std::size_t> etags, enodes;
  gmsh::model::mesh::getElementsByType(gmsh_triangle_type(p), etags, enodes);
  REQUIRE(etags.size() == static_cast<size_t>(hm.num_faces()));
  std::vector<std::vector<std::size_t>> conn(hm.num_faces());
  std::vector<int> idx(n);
  int bad = 0;
  for (size_t e = 0; e < etags.size(); ++e) {
    REQUIRE(etags[e] >= 1);
    REQUIRE(etags[e] <= static_cast<size_t>(hm.num_faces()));
    const int f = static_cast<int>(etags[e]) - 1;
    conn[f].assign(enodes.begin() + e * n, enodes.begin() + (e + 1) * n);
    element_node_indices(hm, f, idx.data());
    for (int k = 0; k < n; ++k) bad += conn[f][k] != static_cast<size_t>(idx[k]) + 1;
  }
  CHECK(bad == 0);

  // Each edge's nodes are shared by its two triangles, listed in reverse order.
  if (p >= 2) {
    std::map<std::pair<std::size_t, std::size_t>, std::vector<std::size_t>> seen;
    int shared = 0, mismatched = 0;
    for (int f = 0; f < hm.num_faces(); ++f)
      for (int j = 0; j < 3; ++j) {
        const std::size_t a = conn[f][j], b = conn[f][(j + 1) % 3];
        std::vector<std::size_t> mids(conn[f].begin() + 3 + j * (p - 1), conn[f].begin() + 3 + (j + 1) * (p - 1));
        auto it = seen.find({b, a});
        if (it != seen.end()) {
          ++shared;
          std::vector<std::size_t> rev(it->second.rbegin(), it->second.rend());
          mismatched += rev != mids;
        } else {
          seen[{a, b}] = mids;
        }
      }
    std::vector<int> uses(hm.E.rows(), 0);
    for (int f = 0; f < hm.num_faces(); ++f)
      for (int j = 0; j < 3; ++j) ++uses[hm.FE(f, j)];
    CHECK(shared == std::count(uses.begin(), uses.end(), 2));  // every interior edge seen twice
    CHECK(mismatched == 0);
  }

  // Entities and their element counts.
  gmsh::vectorpair ents;
  gmsh::model::getEntities(ents, 2);
  std::set<int> ent_tags;
  for (auto& dt : ents) ent_tags.insert(dt.second);
  std::map<int, size_t> expected;
  for (int f = 0; f < hm.num_faces(); ++f) ++expected[hm.entity_of(f)];
  std::set<int> expected_tags;
  for (auto& [t, c] : expected) expected_tags.insert(t);
  CHECK(ent_tags == expected_tags);
  for (int t : ent_tags) {
    // Gmsh 4.8 keeps a pre-sized output vector as it is (preallocation API): clear first.
    etags.clear();
    enodes.clear();
    gmsh::model::mesh::getElementsByType(gmsh_triangle_type(p), etags, enodes, t);
    CHECK(etags.size() == expected[t]);
  }

  // Physical groups and names.
  gmsh::vectorpair groups;
  gmsh::model::getPhysicalGroups(groups, 2);
  REQUIRE(groups.size() == hm.physicals.size());
  for (const PhysicalGroup& g : hm.physicals) {
    std::string name;
    gmsh::model::getPhysicalName(2, g.tag, name);
    CHECK(name == g.name);
    std::vector<int> members;
    gmsh::model::getEntitiesForPhysicalGroup(2, g.tag, members);
    CHECK(std::set<int>(members.begin(), members.end()) == std::set<int>(g.entities.begin(), g.entities.end()));
  }
}

bool have_meshio() {
  return fs::exists("/usr/bin/python3") &&
         std::system("/usr/bin/python3 -c 'import meshio' >/dev/null 2>&1") == 0;
}

// meshio's view of each file, one line per path (a single interpreter start for all):
// "<cell types> <#cells> <#points> <sorted field_data names>", or "ERROR <message>".
std::vector<std::string> meshio_summaries(const std::vector<std::string>& paths) {
  std::string cmd =
      "/usr/bin/python3 -c \"import meshio,sys\n"
      "for f in sys.argv[1:]:\n"
      "  try:\n"
      "    m=meshio.read(f)\n"
      "    print('@', ' '.join(c.type for c in m.cells), sum(len(c.data) for c in m.cells), len(m.points), "
      "' '.join(sorted(m.field_data)))\n"
      "  except Exception as e:\n"
      "    print('@ ERROR', repr(e).replace(chr(10), ' '))\n"
      "\"";
  for (const std::string& p : paths) cmd += " '" + p + "'";
  cmd += " 2>&1";
  std::string out;
  if (FILE* f = popen(cmd.c_str(), "r")) {
    char buf[4096];
    while (fgets(buf, sizeof buf, f)) out += buf;
    pclose(f);
  }
  // meshio prints empty lines of its own; keep only our '@' lines.
  std::vector<std::string> lines;
  std::istringstream is(out);
  for (std::string line; std::getline(is, line);)
    if (line.rfind("@ ", 0) == 0) lines.push_back(line.substr(2));
  return lines;
}

}  // namespace

TEST_CASE("straight high-order mesh: shared edges, Gmsh order, Lobatto consistency") {
  const Mesh m = test_mesh();
  const Topology T = build_topology(m.F, m.num_vertices());
  for (NodeDistribution d : {NodeDistribution::Equispaced, NodeDistribution::Lobatto})
    for (int p = 1; p <= 6; ++p) {
      CAPTURE(p);
      const HighOrderMesh hm = make_straight_high_order(m, T, p, d);
      CHECK(hm.edge_nodes.rows() == T.num_edges() * (p - 1));
      CHECK(hm.face_nodes.rows() == m.num_faces() * (p - 1) * (p - 2) / 2);
      CHECK(all_nodes(hm).rows() == hm.V.rows() + hm.edge_nodes.rows() + hm.face_nodes.rows());
      // Every element's nodes are the reference nodes of d mapped onto its straight triangle,
      // including edges walked backwards (rounding-level differences only).
      const Eigen::MatrixXd ref = triangle_reference_nodes(p, d);
      double err = 0;
      std::vector<int> idx(triangle_node_count(p));
      std::set<int> used;
      for (int f = 0; f < m.num_faces(); ++f) {
        const Eigen::RowVector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
        const Eigen::MatrixXd X = element_nodes(hm, f);
        for (int k = 0; k < X.rows(); ++k)
          err = std::max(err, (X.row(k) - (a + ref(k, 0) * (b - a) + ref(k, 1) * (c - a))).norm());
        element_node_indices(hm, f, idx.data());
        used.insert(idx.begin(), idx.end());
      }
      CHECK(err < 1e-15);
      CHECK(used.size() == static_cast<size_t>(all_nodes(hm).rows()));  // every node used
    }
  CHECK_THROWS_AS(make_straight_high_order(m, T, 11), UsageError);
}

TEST_CASE("every format reads back in Gmsh with identical nodes, elements, entities, groups") {
  GmshSession g;
  const Mesh m = test_mesh();
  const fs::path dir = out_dir();
  for (int p : {1, 2, 3, 4, 5, 6, 8, 10})
    for (const Format& fmt : formats()) {
      CAPTURE(p);
      const std::string fname = fmt.name;
      CAPTURE(fname);
      const HighOrderMesh hm = curved(m, p, p == 4 ? NodeDistribution::Lobatto : NodeDistribution::Equispaced);
      const std::string path = (dir / ("octa_p" + std::to_string(p) + "_" + fmt.name + ".msh")).string();
      write_msh_file(hm, path, fmt.opt);
      check_with_gmsh(hm, path);
      // The stream and string writers produce the same bytes as the file writer.
      std::ifstream in(path, std::ios::binary);
      std::stringstream ss;
      ss << in.rdbuf();
      CHECK(ss.str() == write_msh_string(hm, fmt.opt));
      CHECK(ss.str().find(std::string("nodes ") + to_string(hm.distribution) + " order " + std::to_string(p)) !=
            std::string::npos);
    }
}

TEST_CASE("meshio reads every format") {
  if (!have_meshio()) {
    MESSAGE("meshio not available, skipped");
    return;
  }
  const Mesh m = test_mesh();
  const fs::path dir = out_dir();
  const char* names[] = {"", "", "triangle6", "triangle10", "triangle15", "triangle21", "triangle28"};
  std::vector<std::string> paths, expected;
  for (int p : {2, 3, 4, 5, 6})
    for (const Format& fmt : formats()) {
      const HighOrderMesh hm = curved(m, p);
      const std::string path = (dir / ("meshio_p" + std::to_string(p) + "_" + fmt.name + ".msh")).string();
      write_msh_file(hm, path, fmt.opt);
      // 4.1: one cell block per entity (3); 2.2: meshio merges by type (1). Counts add up.
      std::string types;
      const int nblocks = fmt.opt.version == MshOptions::Version::V41 ? 3 : 1;
      for (int b = 0; b < nblocks; ++b) types += std::string(b ? " " : "") + names[p];
      paths.push_back(path);
      expected.push_back(types + " " + std::to_string(hm.num_faces()) + " " + std::to_string(all_nodes(hm).rows()) +
                         " bottom top");
    }
  const std::vector<std::string> got = meshio_summaries(paths);
  REQUIRE(got.size() == paths.size());
  for (size_t i = 0; i < paths.size(); ++i) {
    CAPTURE(paths[i]);
    CHECK(got[i] == expected[i]);
  }
}

TEST_CASE("single entity without groups: minimal sections") {
  GmshSession g;
  Mesh m = test_mesh();
  m.face_entity.resize(0);
  m.physicals.clear();
  const HighOrderMesh hm = curved(m, 3);
  for (const Format& fmt : formats()) {
    const std::string fname = fmt.name;
      CAPTURE(fname);
    const std::string s = write_msh_string(hm, fmt.opt);
    CHECK(s.find("$Entities") == std::string::npos);
    CHECK(s.find("$PhysicalNames") == std::string::npos);
    const std::string path = (out_dir() / (std::string("plain_") + fmt.name + ".msh")).string();
    write_msh_file(hm, path, fmt.opt);
    gmsh::open(path);
    std::vector<std::size_t> etags, enodes;
    gmsh::model::mesh::getElementsByType(21, etags, enodes);
    CHECK(etags.size() == static_cast<size_t>(hm.num_faces()));
  }
}

TEST_CASE("write_msh_file never leaves a partial or temporary file") {
  const Mesh m = test_mesh();
  const fs::path dir = out_dir() / "atomic";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "out.msh").string();
  HighOrderMesh hm = curved(m, 2);
  write_msh_file(hm, path);
  for (const Format& fmt : formats()) {
    std::ostringstream os(std::ios::binary);
    write_msh(hm, os, fmt.opt);
    CHECK(os.str() == write_msh_string(hm, fmt.opt));
  }
  const auto size_before = fs::file_size(path);
  // A mesh with a NaN node is refused before anything is written; the old file survives.
  hm.edge_nodes(3, 1) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(write_msh_file(hm, path), InputError);
  CHECK(fs::file_size(path) == size_before);
  // Inconsistent arrays are refused too.
  HighOrderMesh broken = curved(m, 3);
  broken.face_nodes.conservativeResize(broken.face_nodes.rows() - 1, 3);
  CHECK_THROWS_AS(write_msh_string(broken), InputError);
  // Unwritable location: throws, creates nothing.
  CHECK_THROWS(write_msh_file(curved(m, 2), (dir / "missing" / "x.msh").string()));
  int files = 0;
  for (auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  CHECK(files == 1);
}

TEST_CASE("write speed, 200k-triangle P4 mesh" * doctest::skip()) {
  // Run with --no-skip: a 317 x 316 grid heightfield, binary and ASCII 4.1.
  const int nx = 317, ny = 316;
  Mesh m;
  m.V.resize((nx + 1) * (ny + 1), 3);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i)
      m.V.row(j * (nx + 1) + i) << i * 0.01, j * 0.01, 0.1 * std::sin(i * 0.05) * std::cos(j * 0.07);
  m.F.resize(2 * nx * ny, 3);
  for (int j = 0, f = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      m.F.row(f++) << a, b, d;
      m.F.row(f++) << a, d, c;
    }
  const HighOrderMesh hm = make_straight_high_order(m, build_topology(m.F, m.num_vertices()), 4);
  for (bool binary : {true, false}) {
    const std::string path = (out_dir() / (binary ? "speed_bin.msh" : "speed_ascii.msh")).string();
    const auto t0 = std::chrono::steady_clock::now();
    write_msh_file(hm, path, {MshOptions::Version::V41, binary});
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    MESSAGE(m.num_faces() << " P4 triangles, " << all_nodes(hm).rows() << " nodes, "
                          << std::string(binary ? "binary" : "ascii") << ": " << fs::file_size(path) / 1e6 << " MB in " << s
                          << " s");
    fs::remove(path);
    const auto t1 = std::chrono::steady_clock::now();
    const size_t bytes = write_msh_string(hm, {MshOptions::Version::V41, binary}).size();
    MESSAGE("  in memory (no disk, no fsync): " << bytes / 1e6 << " MB in "
                                               << std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count()
                                               << " s");
  }
}

TEST_CASE("an entity in two physical groups") {
  GmshSession g;
  Mesh m = test_mesh();
  m.physicals = {{7, "top", {1}}, {9, "bottom", {2, 5}}, {11, "", {1, 5}}};  // unnamed, overlapping
  const HighOrderMesh hm = curved(m, 2);
  for (const Format& fmt : formats()) {
    const std::string fname = fmt.name;
    CAPTURE(fname);
    const std::string path = (out_dir() / ("overlap_" + fname + ".msh")).string();
    write_msh_file(hm, path, fmt.opt);
    gmsh::open(path);
    std::vector<int> members;
    gmsh::model::getEntitiesForPhysicalGroup(2, 11, members);
    CHECK(std::set<int>(members.begin(), members.end()) == std::set<int>{1, 5});
    gmsh::model::getEntitiesForPhysicalGroup(2, 9, members);
    CHECK(std::set<int>(members.begin(), members.end()) == std::set<int>{2, 5});
    std::string name;
    gmsh::model::getPhysicalName(2, 7, name);
    CHECK(name == "top");
    std::vector<std::size_t> etags, enodes;
    gmsh::model::mesh::getElementsByType(9, etags, enodes);
    INFO("elements read back: " << etags.size());
    // 4.1 stores each element once; 2.2 repeats an entity's elements once per group (Gmsh's
    // own 2.2 writer does the same, and its reader keeps the copies): entity 1 (16 faces) and
    // entity 5 (4 faces) are in two groups, entity 2 (12 faces) in one.
    if (fmt.opt.version == MshOptions::Version::V41) CHECK(etags.size() == static_cast<size_t>(hm.num_faces()));
    else CHECK(etags.size() == 16 * 2 + 12 + 4 * 2);
  }
}

TEST_CASE("large meshes: parallel text chunks keep order (ASCII) and match binary") {
  GmshSession g;
  // 90 x 90 grid, P4: 16200 elements and ~130k nodes, several text chunks each.
  const int nx = 90, ny = 90;
  Mesh m;
  m.V.resize((nx + 1) * (ny + 1), 3);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.V.row(j * (nx + 1) + i) << i / 7.0, j / 3.0, std::sin(i * 0.1) / 9.0;
  m.F.resize(2 * nx * ny, 3);
  m.face_entity.resize(2 * nx * ny);
  for (int j = 0, f = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      m.face_entity[f] = i < nx / 3 ? 4 : 2;
      m.F.row(f++) << a, b, d;
      m.face_entity[f] = i < nx / 3 ? 4 : 2;
      m.F.row(f++) << a, d, c;
    }
  m.physicals = {{3, "left", {4}}};
  const HighOrderMesh hm = make_straight_high_order(m, build_topology(m.F, m.num_vertices()), 4);
  REQUIRE(all_nodes(hm).rows() > 3 * 16384);
  for (const Format& fmt : formats()) {
    const std::string fname = fmt.name;
    CAPTURE(fname);
    const std::string path = (out_dir() / ("grid_" + fname + ".msh")).string();
    write_msh_file(hm, path, fmt.opt);
    check_with_gmsh(hm, path);
  }
}

TEST_CASE("concurrent writers produce identical bytes") {
  const HighOrderMesh hm = curved(test_mesh(), 5);
  for (const Format& fmt : formats()) {
    const std::string ref = write_msh_string(hm, fmt.opt);
    std::vector<std::string> out(4);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) threads.emplace_back([&, t] { out[t] = write_msh_string(hm, fmt.opt); });
    for (auto& th : threads) th.join();
    for (const std::string& s : out) CHECK(s == ref);
  }
}
