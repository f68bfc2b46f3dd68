// RAII Gmsh session for tests: initialise quietly, finalise at scope exit; and the triangle mesh
// of an OCC shape as Gmsh makes it (what bench/shapes.py does).
#pragma once
#include "engine/core/mesh.hpp"

#include <gmsh.h>

#include <algorithm>
#include <vector>

struct GmshSession {
  GmshSession() {
    gmsh::initialize();
    gmsh::option::setNumber("General.Terminal", 0);
  }
  ~GmshSession() { gmsh::finalize(); }
};

/// Meshes the current model's surfaces at size h (down to hmin, default h; call inside a
/// GmshSession, after occ::synchronize) and returns the triangles with the nodes they use; with
/// entities, each face tagged with its CAD surface (Mesh::face_entity), as a .msh file keeps them.
inline hocurve::Mesh gmsh_surface_mesh(double h, double hmin = -1, bool entities = false) {
  gmsh::option::setNumber("Mesh.MeshSizeMin", hmin > 0 ? hmin : h);
  gmsh::option::setNumber("Mesh.MeshSizeMax", h);
  gmsh::model::mesh::generate(2);
  std::vector<std::size_t> tags;
  std::vector<double> coord, par;
  gmsh::model::mesh::getNodes(tags, coord, par, -1, -1, true, false);
  std::size_t maxtag = 0;
  for (auto t : tags) maxtag = std::max(maxtag, t);
  std::vector<int> index(maxtag + 1, -1);
  hocurve::Mesh m;
  m.V.resize(static_cast<Eigen::Index>(tags.size()), 3);
  for (size_t i = 0; i < tags.size(); ++i) {
    index[tags[i]] = static_cast<int>(i);
    for (int k = 0; k < 3; ++k) m.V(i, k) = coord[3 * i + k];
  }
  gmsh::vectorpair surfaces;
  gmsh::model::getEntities(surfaces, 2);
  std::vector<int> corners, entity;
  for (const auto& [dim, tag] : surfaces) {
    std::vector<std::size_t> ftags, fnodes;
    gmsh::model::mesh::getElementsByType(2, ftags, fnodes, tag);
    for (std::size_t n : fnodes) corners.push_back(index[n]);
    entity.insert(entity.end(), ftags.size(), tag);
  }
  m.F.resize(static_cast<Eigen::Index>(entity.size()), 3);
  for (size_t f = 0; f < entity.size(); ++f)
    for (int k = 0; k < 3; ++k) m.F(f, k) = corners[3 * f + k];
  if (entities) m.face_entity = Eigen::Map<Eigen::VectorXi>(entity.data(), static_cast<Eigen::Index>(entity.size()));
  return m;
}
