// Gmsh .msh writer for curved tet meshes (MSH 4.1 and 2.2, ASCII and binary): the tets
// (types 4, 11, 29, 30, ...) and their boundary triangles (2, 9, 21, 23, ...) on one node list.
// Pure function of the mesh: no Gmsh, safe on any thread.
//
// Layout: $MeshFormat, $HocurveInfo, $PhysicalNames, $Entities (4.1), $Nodes, $Elements.
// - Nodes: tags 1..#N = rows of X + 1, one block on the volume (4.1).
// - Entities: the surface's entities (face_entity; 1 if none) bounding one volume entity 1.
// - Elements: one triangle block per surface entity (tag = face + 1), then the tets
//   (tag = #F + tet + 1).
// - Physical groups: the volume in group 1 named volume_name; the surface's own groups when
//   it has some, else group 1 (dimension 2) named boundary_name holding every surface entity.
//   In 2.2 an element carries the first group of its entity.
#pragma once
#include "engine/highorder/write_msh.hpp"
#include "engine/volume/tet_mesh.hpp"

#include <string>

namespace hocurve {

struct TetMshOptions {
  MshOptions msh;
  std::string volume_name = "fluid";        ///< PyFR requires a volume group named fluid
  std::string boundary_name = "boundary";   ///< used when the surface has no groups of its own
};

/// Writes tm to sink. Throws InputError for non-finite coordinates before writing anything.
void write_tet_msh(const TetMesh& tm, const ByteSink& sink, const TetMshOptions& opt = {});

/// Writes path atomically (write_file_atomically).
void write_tet_msh_file(const TetMesh& tm, const std::string& path, const TetMshOptions& opt = {});

}  // namespace hocurve
