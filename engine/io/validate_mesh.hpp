// Topology and geometry checks on a freshly read mesh, with precise messages and safe repairs.
#pragma once
#include "engine/core/mesh.hpp"

#include <string>
#include <vector>

namespace hocurve {

struct ValidateOptions {
  bool fix_orientation = true;          ///< flip faces to make each manifold component consistent
  bool drop_duplicate_faces = true;     ///< remove faces that repeat another face's three vertices
  bool drop_degenerate_faces = true;    ///< remove faces with a repeated vertex index
  bool drop_unused_vertices = true;     ///< compact V to the vertices faces use
  bool flip_zero_area_caps = true;      ///< zero-area faces closing T-junctions: edge-flipped away
  bool drop_zero_area_flaps = true;     ///< zero-area faces sharing at most one edge: removed
  bool orient_outward = true;           ///< flip closed orientable components whose signed volume is negative
  std::string name;                     ///< file name used in messages (may be empty)
};

/// What validate_mesh found and did. Fatal problems throw InputError instead.
struct ValidateReport {
  long long duplicate_faces = 0, degenerate_faces = 0, zero_area_faces = 0, unused_vertices = 0;
  long long zero_area_caps_flipped = 0;  ///< zero-area faces removed by an edge flip (flip_zero_area_caps)
  long long zero_area_flaps_removed = 0; ///< zero-area faces removed outright (drop_zero_area_flaps)
  long long boundary_edges = 0, nonmanifold_edges = 0, nonmanifold_vertices = 0;
  long long flipped_faces = 0;          ///< faces re-oriented for consistency
  long long non_orientable_components = 0;
  long long outward_flipped_components = 0;  ///< closed components turned outward (included in flipped_faces)
  int components = 0;                   ///< edge-connected face components
  std::vector<std::string> warnings;    ///< one line each, naming face/vertex indices
};

/// Bounding-box diagonals validate_mesh accepts (InputError outside them).
inline constexpr double kMinDiagonal = 1e-30, kMaxDiagonal = 1e30;

/// Checks mesh (finite coordinates, indices in range, non-empty, a diagonal in range) and repairs what can be
/// repaired safely (per options). Throws InputError for what cannot be used.
ValidateReport validate_mesh(Mesh& mesh, const ValidateOptions& opt = {});

}  // namespace hocurve
