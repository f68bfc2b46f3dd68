// Closed-surface checks, shell components and nesting by winding numbers.
#include "engine/volume/shells.hpp"

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/core/union_find.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace hocurve {

namespace {

std::string edge_text(const Mesh& mesh, int a, int b) {
  std::ostringstream s;
  s << "edge (" << a << ", " << b << ") at (" << mesh.V(a, 0) << ", " << mesh.V(a, 1) << ", " << mesh.V(a, 2)
    << ") - (" << mesh.V(b, 0) << ", " << mesh.V(b, 1) << ", " << mesh.V(b, 2) << ")";
  return s.str();
}

// Does face f walk edge (a, b) from a to b?
bool walks(const Mesh& mesh, int f, int a, int b) {
  for (int j = 0; j < 3; ++j)
    if (mesh.F(f, j) == a && mesh.F(f, (j + 1) % 3) == b) return true;
  return false;
}

}  // namespace

Shells find_shells(const Mesh& mesh) {
  if (mesh.num_faces() == 0) throw InputError("surface", "no triangles: nothing to fill with tets");
  const Topology T = build_topology(mesh.F, mesh.num_vertices());
  std::vector<int> root(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) root[f] = f;
  for (int e = 0; e < T.num_edges(); ++e) {
    const auto& fs = T.edge_faces[e];
    const int a = T.E(e, 0), b = T.E(e, 1);
    if (fs.size() == 1)
      throw InputError("surface " + edge_text(mesh, a, b), "open: the edge has one triangle (face " +
                                                              std::to_string(fs[0]) + "); a volume needs a closed surface");
    if (fs.size() > 2)
      throw InputError("surface " + edge_text(mesh, a, b),
                       "non-manifold: " + std::to_string(fs.size()) + " triangles share the edge");
    if (walks(mesh, fs[0], a, b) == walks(mesh, fs[1], a, b))
      throw InputError("surface " + edge_text(mesh, a, b), "faces " + std::to_string(fs[0]) + " and " +
                                                              std::to_string(fs[1]) + " are oriented inconsistently");
    root[find_root(root, fs[0])] = find_root(root, fs[1]);
  }
  Shells sh;
  sh.shell_of_face.assign(mesh.num_faces(), -1);
  std::vector<int> id(mesh.num_faces(), -1);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    int& r = id[find_root(root, f)];
    if (r < 0) r = sh.count++;
    sh.shell_of_face[f] = r;
  }
  // Nesting: shell s is inside shell t when t winds around one of s's vertices.
  std::vector<int> probe(sh.count, -1);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (probe[sh.shell_of_face[f]] < 0) probe[sh.shell_of_face[f]] = mesh.F(f, 0);
  std::vector<std::vector<char>> inside(sh.count, std::vector<char>(sh.count, 0));
  sh.depth.assign(sh.count, 0);
  sh.parent.assign(sh.count, -1);
  if (sh.count > 1)
    for (int s = 0; s < sh.count; ++s)
      for (int t = 0; t < sh.count; ++t)
        if (s != t && std::abs(winding_number(mesh, sh, t, mesh.V.row(probe[s]).transpose())) > 0.5) {
          inside[s][t] = 1;
          ++sh.depth[s];
        }
  for (int s = 0; s < sh.count; ++s)
    for (int t = 0; t < sh.count; ++t)
      if (inside[s][t] && sh.depth[t] == sh.depth[s] - 1) sh.parent[s] = t;
  return sh;
}

double winding_number(const Mesh& mesh, const Shells& shells, int s, const Eigen::Vector3d& x) {
  // Sum of signed solid angles (Van Oosterom & Strackee) over 4 pi.
  double sum = 0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (shells.shell_of_face[f] != s) continue;
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)).transpose() - x, b = mesh.V.row(mesh.F(f, 1)).transpose() - x,
                          c = mesh.V.row(mesh.F(f, 2)).transpose() - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    sum += 2 * std::atan2(num, den);
  }
  return sum / (4 * M_PI);
}

}  // namespace hocurve
