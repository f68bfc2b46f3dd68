// Non-manifold inputs (two closed parts touching at a point, as in raw Thingi10K files; fins and
// inner walls hanging off an edge): the faces around such a vertex form several fans. The
// collapse machinery needs one fan per vertex and two faces per edge, so each extra fan gets its
// own copy of the vertex; the copies sit at the same point and must never move
// (DecimateOptions::pinned_vertices), so the parts still meet there, and rejoin_vertex_copies puts
// them back together in the coarse high-order mesh.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

struct FanSplit {
  Mesh mesh;                  ///< the input with one vertex per fan (copies appended; faces, entities, groups kept)
  std::vector<int> pinned;    ///< vertices of mesh at a split point (the original and its copies)
  std::vector<int> original;  ///< per vertex of mesh: the input vertex it is (a copy of)
  int split_vertices = 0;     ///< input vertices that had several fans
  int nonmanifold_edges = 0;  ///< input edges shared by more than two faces (cut open)
};

/// Number of fans around vertex v: groups of its faces linked through edges at v that have
/// exactly two faces (an edge of more faces links none of them). fan[i] = the fan of the i-th
/// face of T.faces_of(v).
int vertex_fans(const Mesh& m, const Topology& T, int v, std::vector<int>& fan);

/// Gives every vertex whose faces form several fans one copy per fan after the first. Edges of
/// more than two faces are thereby cut open: each of their faces keeps its own copy of the edge.
FanSplit split_vertex_fans(const Mesh& m);

/// Joins the copies again: vertices v with same[v] != v become vertex same[v] (same[same[v]] ==
/// same[v]), edges that then join the same two vertices become one, and vertices left unused are
/// dropped. A joined edge takes the nodes of a copy with two faces (an inner edge of its part, as
/// under a fin), else the mean of the copies (open boundaries fitted to the same dense curve).
/// Face nodes, entities and groups are kept. Validity is not checked here.
/// same[] for rejoin_vertex_copies of a coarse mesh decimated from split.mesh, whose vertex c
/// continues split vertex origin[c]: the first coarse vertex continuing the same input vertex
/// (itself when origin[c] < 0).
std::vector<int> coarse_vertex_copies(const FanSplit& split, const std::vector<int>& origin);

HighOrderMesh rejoin_vertex_copies(const HighOrderMesh& hm, const std::vector<int>& same);

}  // namespace hocurve
