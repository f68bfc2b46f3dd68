// Curved tets on hocurve's curved surface: certified valid at P2-P4 on a sphere, a torus and a
// thin spherical shell; the boundary is `curve`'s surface bit for bit; Gmsh reads the file.
#include <doctest/doctest.h>
#include <gmsh.h>

#include "gmsh_session.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"
#include "engine/io/validate_mesh.hpp"
#include "engine/volume/tet_basis.hpp"
#include "engine/volume/volume_mesh.hpp"
#include "engine/volume/write_tet_msh.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

using namespace hocurve;

namespace {

// A Gmsh OCC shape's surface mesh at size h, validated as the CLI validates its inputs.
Mesh occ_surface(const std::string& shape, double h) {
  Mesh m;
  {
    GmshSession gs;
    if (shape == "sphere") {
      gmsh::model::occ::addSphere(0, 0, 0, 1);
    } else if (shape == "torus") {
      gmsh::model::occ::addTorus(0, 0, 0, 1, 0.35);
    } else if (shape == "nested") {  // three concentric spheres: radii 1, 0.8, 0.5
      for (const double r : {1.0, 0.8, 0.5}) gmsh::model::occ::addSphere(0, 0, 0, r);
    } else {  // thin shell: sphere of radius 1 minus radius 0.95
      const int a = gmsh::model::occ::addSphere(0, 0, 0, 1), b = gmsh::model::occ::addSphere(0, 0, 0, 0.95);
      gmsh::vectorpair out;
      std::vector<gmsh::vectorpair> map;
      gmsh::model::occ::cut({{3, a}}, {{3, b}}, out, map);
    }
    gmsh::model::occ::synchronize();
    m = gmsh_surface_mesh(h);
  }
  validate_mesh(m);
  return m;
}

VolumeOptions options(int p) {
  VolumeOptions o;
  o.curve.order = p;
  return o;
}

// Corner -> lattice weight of node k of an element with the given corners and lattice rows.
std::map<int, int> weights(const int* corners, const Eigen::RowVectorXi& lattice, int p) {
  std::map<int, int> w;
  const int n = static_cast<int>(lattice.size());
  int rest = p;
  for (int i = 0; i < n; ++i) {
    if (lattice[i]) w[corners[i + 1]] = lattice[i];
    rest -= lattice[i];
  }
  if (rest) w[corners[0]] = rest;
  return w;
}

// Every boundary triangle's nodes are the nodes its tet has at the same lattice positions.
void check_boundary_faces(const TetMesh& tm) {
  const int p = tm.order;
  const Eigen::MatrixXi TL = tet_lattice(p), FL = triangle_lattice(p);
  std::map<std::array<int, 3>, int> tet_of;
  for (int t = 0; t < tm.num_tets(); ++t)
    for (const auto& f : {std::array<int, 3>{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}}) {
      std::array<int, 3> c{tm.T(t, f[0]), tm.T(t, f[1]), tm.T(t, f[2])};
      std::sort(c.begin(), c.end());
      tet_of[c] = t;
    }
  long long bad = 0;
  for (int f = 0; f < tm.B.rows(); ++f) {
    std::array<int, 3> c{tm.B(f, 0), tm.B(f, 1), tm.B(f, 2)};
    std::sort(c.begin(), c.end());
    REQUIRE(tet_of.count(c));
    const int t = tet_of[c];
    const int tc[4] = {tm.T(t, 0), tm.T(t, 1), tm.T(t, 2), tm.T(t, 3)}, fc[3] = {tm.B(f, 0), tm.B(f, 1), tm.B(f, 2)};
    std::map<std::map<int, int>, int> tet_nodes;
    for (int k = 0; k < TL.rows(); ++k) tet_nodes[weights(tc, TL.row(k), p)] = tm.T(t, k);
    for (int k = 0; k < FL.rows(); ++k) bad += tet_nodes.at(weights(fc, FL.row(k), p)) != tm.B(f, k);
  }
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("volume: certified valid P2-P4 tets, boundary = curve's surface") {
  const std::pair<const char*, double> shapes[] = {{"sphere", 0.35}, {"torus", 0.25}, {"shell", 0.3}};
  for (const auto& [shape, h] : shapes) {
    const Mesh surface = occ_surface(shape, h);
    for (int p = 2; p <= 4; ++p) {
      CAPTURE(shape);
      CAPTURE(p);
      const VolumeResult r = volume_mesh(surface, options(p));
      MESSAGE(std::string(shape) << " P" << p << ": " << r.quality.tets << " tets, invalid before " << r.invalid_before
                    << ", after " << r.quality.invalid << ", min/p1 scaled J " << r.quality.min_scaled_jacobian
                    << " / " << r.quality.p1_scaled_jacobian << ", optimize " << r.optimize.seconds << " s");
      CHECK(r.quality.invalid == 0);
      CHECK(r.quality.min_scaled_jacobian > 0);
      CHECK(r.shells == (std::string(shape) == "shell" ? 2 : 1));
      // The boundary is hocurve curve's surface, bit for bit, from an independent run.
      const CurveResult c = curve_mesh(surface, options(p).curve);
      long long differ = 0;
      for (int f = 0; f < c.mesh.num_faces(); ++f) {
        const Eigen::MatrixXd X = element_nodes(c.mesh, f);
        for (Eigen::Index k = 0; k < X.rows(); ++k) differ += X.row(k) != r.mesh.X.row(r.mesh.B(f, k));
      }
      CHECK(differ == 0);
      check_boundary_faces(r.mesh);
    }
  }
}

TEST_CASE("volume: Gmsh reads the file back (types, counts, groups, its det J = ours)") {
  const Mesh surface = occ_surface("shell", 0.3);
  const std::filesystem::path dir = std::filesystem::path(HOCURVE_BINARY_DIR) / "test-output" / "volume";
  std::filesystem::create_directories(dir);
  for (int p = 2; p <= 4; ++p) {
    const VolumeResult r = volume_mesh(surface, options(p));
    for (const bool v41 : {true, false})
      for (const bool binary : {false, true}) {
        CAPTURE(p);
        CAPTURE(v41);
        CAPTURE(binary);
        TetMshOptions w;
        w.msh.version = v41 ? MshOptions::Version::V41 : MshOptions::Version::V22;
        w.msh.binary = binary;
        const std::string path = (dir / ("shell_p" + std::to_string(p) + ".msh")).string();
        write_tet_msh_file(r.mesh, path, w);
        GmshSession gs;
        gmsh::open(path);
        std::vector<std::size_t> tags, nodes, ttags, tnodes;  // Gmsh 4.8 appends to its outputs: fresh vectors
        gmsh::model::mesh::getElementsByType(gmsh_tet_type(p), ttags, tnodes);
        CHECK(ttags.size() == static_cast<std::size_t>(r.mesh.num_tets()));
        gmsh::model::mesh::getElementsByType(gmsh_triangle_type(p), tags, nodes);
        CHECK(tags.size() == static_cast<std::size_t>(r.mesh.B.rows()));
        // Node tags are our rows + 1: the first triangle's nodes are ours.
        for (int k = 0; k < r.mesh.B.cols(); ++k) CHECK(nodes[k] == static_cast<std::size_t>(r.mesh.B(0, k)) + 1);
        std::vector<std::size_t> ntags;
        std::vector<double> xyz, par;
        gmsh::model::mesh::getNodes(ntags, xyz, par);
        CHECK(ntags.size() == static_cast<std::size_t>(r.mesh.X.rows()));
        // Gmsh's own Lagrange map of our tets gives our det J at every sample: the node order is Gmsh's.
        if (v41 && !binary) {
          const TetJacobianBasis b(p);
          const Eigen::MatrixXd uvw = tet_bernstein_lattice(b.d);
          std::vector<double> local, jac, det, pts;
          for (Eigen::Index i = 0; i < uvw.rows(); ++i)
            for (int k = 0; k < 3; ++k) local.push_back(uvw(i, k));
          gmsh::model::mesh::getJacobians(gmsh_tet_type(p), local, jac, det, pts);
          REQUIRE(det.size() == static_cast<std::size_t>(r.mesh.num_tets() * uvw.rows()));
          double worst = 0;
          for (std::size_t e = 0; e < ttags.size(); ++e) {
            const int t = static_cast<int>(ttags[e] - r.mesh.B.rows() - 1);  // element tag = #F + tet + 1
            const Eigen::VectorXd J = jacobian_samples(b, r.mesh.tet_nodes(t));
            for (Eigen::Index i = 0; i < J.size(); ++i)
              worst = std::max(worst, std::abs(det[e * J.size() + i] - J[i]) / J.cwiseAbs().maxCoeff());
          }
          CHECK(worst < 1e-9);
        }
        gmsh::vectorpair groups;
        gmsh::model::getPhysicalGroups(groups);
        std::map<int, std::string> names;
        for (const auto& [dim, tag] : groups) gmsh::model::getPhysicalName(dim, tag, names[dim]);
        CHECK(names[3] == "fluid");
        CHECK(names[2] == "boundary");
      }
  }
}

TEST_CASE("volume: an open surface is refused, naming the edge") {
  Mesh m = occ_surface("sphere", 0.5);
  m.F.conservativeResize(m.F.rows() - 1, 3);
  try {
    volume_mesh(m, options(2));
    FAIL("an open surface was accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("open") != std::string::npos);
    CHECK(std::string(e.what()).find("edge (") != std::string::npos);
  }
}

TEST_CASE("volume: the curved unit ball's volume converges at order >= P+1 as h halves (P2)") {
  // The volume is the integral of det J; a Bernstein polynomial of degree d integrates to
  // (tet volume) / #coefficients, so the mean coefficient / 6 is each tet's exact volume.
  const TetJacobianBasis b(2);
  std::vector<double> err;
  for (const double h : {0.4, 0.2, 0.1}) {
    const VolumeResult r = volume_mesh(occ_surface("sphere", h), options(2));
    double v = 0;
    for (int t = 0; t < r.mesh.num_tets(); ++t) v += (b.to_bernstein * jacobian_samples(b, r.mesh.tet_nodes(t))).mean() / 6;
    err.push_back(std::abs(v - 4 * M_PI / 3));
    MESSAGE("h " << h << ": " << r.mesh.num_tets() << " tets, volume error " << err.back());
  }
  for (std::size_t i = 1; i < err.size(); ++i) CHECK(std::log2(err[i - 1] / err[i]) >= 3);
}

TEST_CASE("volume: a self-intersecting surface is refused, naming two crossing faces") {
  Mesh a = occ_surface("sphere", 0.5), b = a;
  b.V.col(0).array() += 0.8;  // a second sphere through the first
  Mesh m;
  m.V.resize(a.V.rows() * 2, 3);
  m.V << a.V, b.V;
  m.F.resize(a.F.rows() * 2, 3);
  m.F << a.F, b.F.array() + static_cast<int>(a.V.rows());
  try {
    volume_mesh(m, options(2));
    FAIL("a self-intersecting surface was accepted");
  } catch (const InputError& e) {
    MESSAGE(std::string(e.what()));
    CHECK(std::string(e.what()).find("self-intersecting") != std::string::npos);
    CHECK(std::string(e.what()).find("faces ") != std::string::npos);
  }
}

TEST_CASE("volume: nested shells: a shell in a shell is a hole, a shell in the hole a new volume") {
  const VolumeResult r = volume_mesh(occ_surface("nested", 0.3), options(2));
  CHECK(r.shells == 3);
  CHECK(r.quality.invalid == 0);
  int in_hole = 0, inner = 0, outer = 0;
  for (int t = 0; t < r.mesh.num_tets(); ++t) {
    const double c = r.mesh.tet_nodes(t).topRows(4).colwise().mean().norm();
    in_hole += c > 0.5 && c < 0.8;
    inner += c < 0.5;
    outer += c > 0.8;
  }
  CHECK(in_hole == 0);
  CHECK(inner > 0);
  CHECK(outer > 0);
}
