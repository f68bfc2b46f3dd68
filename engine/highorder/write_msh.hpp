// Streaming Gmsh .msh writer for high-order triangle meshes (MSH 4.1 and 2.2, ASCII and
// binary). Pure function of the mesh: no Gmsh, no global state, safe to call from any thread.
//
// Layout (Gmsh's MSH 4.1 and 2.2 file formats): $MeshFormat, [$HocurveInfo], [$PhysicalNames], [$Entities] (4.1),
// $Nodes, $Elements.
// - Nodes: every node in global index order (tags 1..N = all_nodes(hm) rows + 1). In 4.1 they
//   form one block on the first surface entity (Gmsh and meshio resolve element nodes by tag,
//   whatever entity a node block names).
// - Elements: element tag = face index + 1; one block per surface entity (distinct
//   face_entity values, ascending), faces in index order within a block. (2.2 copies of an
//   element in its 2nd, 3rd... group are numbered after the last face.)
// - $PhysicalNames (groups with a name) and $Entities (4.1; one discrete surface per entity
//   with its physical tags and bounding box, no boundary) are written when the mesh has
//   physical groups or several entities. In 2.2 an element carries 2 tags (physical,
//   entity); an entity in k > 1 groups gets its elements written k times, once per group, as
//   Gmsh itself does (Gmsh reads the copies back as separate elements: prefer 4.1 then).
// - $HocurveInfo: one ASCII line "nodes <equispaced|lobatto> order <p> generator hocurve"
//   right after $EndMeshFormat (also in binary files, where it stays text). Readers skip
//   sections they do not know: checked with Gmsh 4.8.4 (C++ API, open) and meshio 5.0 for
//   4.1/2.2 ASCII/binary (tests/highorder/test_write_msh.cpp). It matters because .msh
//   readers interpolate the nodes as equispaced Lagrange nodes: a Lobatto file describes a
//   (slightly) different surface to them.
#pragma once
#include "engine/highorder/high_order_mesh.hpp"

#include <functional>
#include <ostream>
#include <string>

namespace hocurve {

struct MshOptions {
  enum class Version { V41, V22 } version = Version::V41;
  bool binary = false;
  bool write_info = true;  ///< write the $HocurveInfo section (node distribution, order)
};

/// Writes hm to os. Throws InputError for an inconsistent mesh (wrong array sizes, non-finite
/// coordinates) before writing anything, std::runtime_error if the stream fails.
void write_msh(const HighOrderMesh& hm, std::ostream& os, const MshOptions& opt = {});

/// The file as a string (tests, HTTP responses).
std::string write_msh_string(const HighOrderMesh& hm, const MshOptions& opt = {});

/// Writes path atomically: a temporary file in the same directory, flushed, fsync'ed and
/// renamed onto path. On any error the temporary is removed and path is left untouched.
void write_msh_file(const HighOrderMesh& hm, const std::string& path, const MshOptions& opt = {});

/// Where a writer hands its bytes, in order.
using ByteSink = std::function<void(const char*, size_t)>;

/// Writes path atomically from the bytes produce gives its sink: a temporary file in the same
/// directory, flushed, fsync'ed and renamed onto path. On any error the temporary is removed
/// and path is left untouched. (write_msh_file; also the tet writer's.)
void write_file_atomically(const std::string& path, const std::function<void(const ByteSink&)>& produce);

}  // namespace hocurve
