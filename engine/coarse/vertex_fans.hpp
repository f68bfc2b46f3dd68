// Non-manifold vertices (two closed parts touching at a point, as in raw Thingi10K files): the
// faces around such a vertex form several fans. The collapse machinery needs one fan per vertex,
// so each extra fan gets its own copy of the vertex; the copies sit at the same point and must
// never move (DecimateOptions::pinned_vertices), so the parts still touch there.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <vector>

namespace hocurve {

struct FanSplit {
  Mesh mesh;                  ///< the input with one vertex per fan (copies appended; faces, entities, groups kept)
  std::vector<int> pinned;    ///< vertices of mesh at a split point (the original and its copies)
  int split_vertices = 0;     ///< input vertices that had several fans
};

/// Number of fans around vertex v; fan[i] = the fan of the i-th face of T.faces_of(v).
int vertex_fans(const Mesh& m, const Topology& T, int v, std::vector<int>& fan);

/// Gives every vertex whose faces form several fans (groups of faces around it linked through
/// edges at the vertex) one copy per fan after the first. Edges shared by more than two faces are
/// left as they are (decimate refuses them).
FanSplit split_vertex_fans(const Mesh& m);

}  // namespace hocurve
