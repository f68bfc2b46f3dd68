// Reading linear triangle surface meshes from bytes or files, format detected from content.
#pragma once
#include "engine/core/mesh.hpp"

#include <string>
#include <string_view>
#include <vector>

namespace hocurve {

struct ReadOptions {
  /// Merge exactly repeated vertex positions: STL stores each facet's own points; indexed formats
  /// (OBJ, PLY, OFF, .msh) may repeat positions at per-face exports or assembled parts' seams.
  bool weld = true;
  /// Then merge vertices closer than this x the bounding-box diagonal of the vertices faces use
  /// (0: none): CAD exports whose faces were tessellated apart repeat their shared border points up
  /// to the last digits, and unmerged every such seam is an open boundary (a soup of such faces
  /// curved nothing). 1e-9 is far below float32 STL resolution (6e-8) and any modelled detail;
  /// marching-tetrahedra vertices 3e-6 apart stay apart.
  double weld_tolerance = 1e-9;
};

struct ReadReport {
  std::string format;            ///< "stl-ascii", "stl-binary", "obj", "ply-ascii", "ply-binary", "off", "msh2", "msh4"
  bool gzip = false;             ///< the input was gzip-compressed
  long long facets_read = 0;     ///< triangles read (after fan-splitting polygons)
  long long welded_vertices = 0; ///< repeated positions merged (exactly or within weld_tolerance)
  std::vector<std::string> warnings;  ///< non-fatal problems, each naming where
};

struct ReadResult {
  Mesh mesh;
  ReadReport report;
};

/// Reads a mesh from memory. `name` is used in messages (and as a weak format hint).
/// Throws InputError (what, where, why) on anything it cannot read; never returns a partial mesh.
ReadResult read_mesh_bytes(std::string_view bytes, const std::string& name, const ReadOptions& opt = {});

/// Reads a mesh file (any supported format, optionally gzip-compressed).
ReadResult read_mesh_file(const std::string& path, const ReadOptions& opt = {});

/// Cheap content sniffing: the format `read_mesh_bytes` would use for these bytes ("stl-ascii",
/// "stl-binary", "obj", "ply-ascii", "ply-binary", "off", "msh2", "msh4"), or "" when unknown.
/// gzip input is looked through (only its first 64 KiB are inflated), so the answer is the inner
/// format. `bytes` may be only the beginning of a file, except that a binary STL without a
/// recognisable header is told apart by its exact size (84 + 50 n bytes). `name` is a weak hint.
std::string detect_format(std::string_view bytes, const std::string& name);

/// Inflates gzip (or zlib) data; throws InputError(name, ...) when it is corrupt or truncated.
std::string gunzip(std::string_view bytes, const std::string& name);

}  // namespace hocurve
