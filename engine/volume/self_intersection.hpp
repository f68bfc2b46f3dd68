// Locating where a surface crosses itself, to name the place when the tet mesher refuses it.
#pragma once
#include "engine/core/mesh.hpp"

#include <optional>
#include <utility>

namespace hocurve {

/// The first pair of faces (by index) that share no vertex and cross: an edge of one passes
/// through the other (signed volumes; touching and coplanar overlaps are not reported).
/// Sweep over the faces' x-extents, then exact-enough double predicates.
std::optional<std::pair<int, int>> find_self_intersection(const Mesh& mesh);

}  // namespace hocurve
