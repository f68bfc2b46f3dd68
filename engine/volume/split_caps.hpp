// Splitting cap tets: a tet with two faces on the boundary has two corners whose three edges
// are all boundary edges, so det J there is fixed by the curved surface alone; where the
// surface bends into the tet no inside node can unfold it. Splitting its inside edge gives
// each of those corners an inside edge.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/volume/gmsh_tets.hpp"

namespace hocurve {

/// Splits at its midpoint the inside edge (the one joining the two corners off the shared
/// boundary edge) of every tet of lin with two faces among surface's triangles, unless that
/// edge is itself a surface edge; every tet around a split edge is cut in two. New vertices
/// are appended to lin.V; orientation is kept. Returns the number of edges split.
long long split_cap_tets(LinearTets& lin, const Mesh& surface);

}  // namespace hocurve
