// Order-p tets from linear ones, their boundary nodes taken from the curved surface.
#pragma once
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/volume/gmsh_tets.hpp"
#include "engine/volume/tet_mesh.hpp"

namespace hocurve {

/// Raises lin's tets to surface.order: every node on a boundary edge or face is the curved
/// surface's own node (same coordinates, bit for bit), matched by the barycentric lattice
/// position it has on its corners, so edge orientations and face node orders never need
/// guessing; every other node sits on the straight tet. surface must be equispaced and its
/// vertices must be lin's first rows (generate_linear_tets keeps them).
TetMesh elevate_tets(const LinearTets& lin, const HighOrderMesh& surface);

}  // namespace hocurve
