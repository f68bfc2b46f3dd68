// One discrete surface per shell, a GEO surface loop and volume per region, generate(3) with
// node renumbering off (reference/volume.md); then the boundary is checked against the input.
#include "engine/volume/gmsh_tets.hpp"

#include "engine/core/error.hpp"
#include "engine/core/stopwatch.hpp"

#include <gmsh.h>

#include <algorithm>
#include <array>
#include <set>
#include <string>

namespace hocurve {

namespace {

struct Session {  // Gmsh for one call: quiet, errors as exceptions, always finalized
  Session() {
    gmsh::initialize();
    gmsh::option::setNumber("General.Terminal", 0);
  }
  ~Session() { gmsh::finalize(); }
};

void add_surfaces(const Mesh& s, const Shells& shells) {
  std::vector<std::size_t> tags(s.num_vertices());
  std::vector<double> xyz(3 * tags.size());
  for (int v = 0; v < s.num_vertices(); ++v) {
    tags[v] = static_cast<std::size_t>(v) + 1;
    for (int k = 0; k < 3; ++k) xyz[3 * v + k] = s.V(v, k);
  }
  std::vector<std::vector<std::size_t>> conn(shells.count);
  for (int f = 0; f < s.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) conn[shells.shell_of_face[f]].push_back(static_cast<std::size_t>(s.F(f, k)) + 1);
  for (int sh = 0; sh < shells.count; ++sh) gmsh::model::addDiscreteEntity(2, sh + 1);
  gmsh::model::mesh::addNodes(2, 1, tags, xyz);  // nodes are found by tag from every entity
  for (int sh = 0; sh < shells.count; ++sh) gmsh::model::mesh::addElementsByType(sh + 1, 2, {}, conn[sh]);
  for (int sh = 0; sh < shells.count; ++sh) {
    if (shells.depth[sh] % 2) continue;
    std::vector<int> loops = {gmsh::model::geo::addSurfaceLoop({sh + 1})};
    for (int c = 0; c < shells.count; ++c)
      if (shells.parent[c] == sh) loops.push_back(gmsh::model::geo::addSurfaceLoop({c + 1}));
    gmsh::model::geo::addVolume(loops);
  }
  gmsh::model::geo::synchronize();
}

LinearTets read_tets(int num_surface_vertices) {
  std::vector<std::size_t> ntags;
  std::vector<double> xyz, par;
  gmsh::model::mesh::getNodes(ntags, xyz, par, -1, -1, false, false);
  std::size_t maxtag = 0;
  for (std::size_t t : ntags) maxtag = std::max(maxtag, t);
  // Surface vertices keep tags 1..#V (Mesh.Renumber = 0); the others follow in tag order.
  std::vector<int> index(maxtag + 1, -1);
  std::vector<std::size_t> order(ntags.size());
  for (std::size_t i = 0; i < ntags.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ntags[a] < ntags[b]; });
  order.erase(std::unique(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ntags[a] == ntags[b]; }),
              order.end());
  LinearTets out;
  out.V.resize(static_cast<Eigen::Index>(order.size()), 3);
  for (std::size_t r = 0; r < order.size(); ++r) {
    const std::size_t i = order[r];
    index[ntags[i]] = static_cast<int>(r);
    for (int k = 0; k < 3; ++k) out.V(static_cast<Eigen::Index>(r), k) = xyz[3 * i + k];
  }
  for (int v = 0; v < num_surface_vertices; ++v)
    if (v >= out.V.rows() || index[v + 1] != v)
      throw std::runtime_error("Gmsh renumbered the surface's vertices (vertex " + std::to_string(v) + ")");
  std::vector<std::size_t> etags, enodes;
  gmsh::model::mesh::getElementsByType(4, etags, enodes);
  out.T.resize(static_cast<Eigen::Index>(etags.size()), 4);
  for (Eigen::Index t = 0; t < out.T.rows(); ++t) {
    for (int k = 0; k < 4; ++k) out.T(t, k) = index[enodes[4 * t + k]];
    const Eigen::RowVector3d a = out.V.row(out.T(t, 0)), b = out.V.row(out.T(t, 1)) - a,
                             c = out.V.row(out.T(t, 2)) - a, d = out.V.row(out.T(t, 3)) - a;
    const double det = b.dot(c.cross(d));
    if (det < 0) std::swap(out.T(t, 1), out.T(t, 2));
  }
  return out;
}

// The tets' boundary faces (faces of one tet) must be exactly the surface's triangles.
void check_boundary(const Mesh& s, const LinearTets& lin) {
  using Face = std::array<int, 3>;
  auto key = [](int a, int b, int c) {
    Face f{a, b, c};
    std::sort(f.begin(), f.end());
    return f;
  };
  std::vector<Face> faces;
  faces.reserve(4 * lin.T.rows());
  const int local[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {3, 1, 2}};
  for (Eigen::Index t = 0; t < lin.T.rows(); ++t)
    for (const auto& l : local) faces.push_back(key(lin.T(t, l[0]), lin.T(t, l[1]), lin.T(t, l[2])));
  std::sort(faces.begin(), faces.end());
  std::set<Face> boundary;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i;
    while (j < faces.size() && faces[j] == faces[i]) ++j;
    if (j - i == 1) boundary.insert(faces[i]);
    i = j;
  }
  long long missing = 0;
  int first = -1;
  for (int f = 0; f < s.num_faces(); ++f)
    if (!boundary.erase(key(s.F(f, 0), s.F(f, 1), s.F(f, 2))) && missing++ == 0) first = f;
  if (missing || !boundary.empty())
    throw InputError("surface" + (first >= 0 ? " face " + std::to_string(first) : std::string()),
                     "Gmsh's tets do not keep the surface's triangles (" + std::to_string(missing) +
                         " missing, " + std::to_string(boundary.size()) +
                         " new boundary faces: Steiner points or a self-intersecting surface)");
}

}  // namespace

LinearTets generate_linear_tets(const Mesh& surface, const Shells& shells, const LinearTetOptions& opt) {
  const auto t0 = Clock::now();
  Session session;
  LinearTets out;
  try {
    gmsh::model::add("hocurve_volume");
    gmsh::option::setNumber("Mesh.Renumber", 0);
    gmsh::option::setNumber("Mesh.Algorithm3D", opt.algorithm);
    gmsh::option::setNumber("Mesh.MeshSizeFactor", opt.size_factor);
    if (opt.size > 0) gmsh::option::setNumber("Mesh.MeshSizeMax", opt.size);
    add_surfaces(surface, shells);
    gmsh::model::mesh::generate(3);
    out = read_tets(surface.num_vertices());
  } catch (const std::string& e) {  // Gmsh 4.8 throws its message as a string
    throw InputError("surface", "Gmsh could not fill it with tets (" + e + ")");
  }
  check_boundary(surface, out);
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace hocurve
