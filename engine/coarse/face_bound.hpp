// The fewest triangles any mesh can have that keeps a mesh's topology, its corners and its
// feature curves: what a decimation that keeps them can reach at best.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <vector>

namespace hocurve {

/// A lower bound on the face count of a triangle mesh with the topology of m (its Euler
/// characteristic and open boundary) that keeps every corner (corner[v]) as a vertex and every
/// feature curve (chains of edge_feature edges between corners, or closed loops) as a chain of
/// edges: a closed loop needs 3 vertices, a loop from a corner back to it 2 more, the second and
/// later curves between the same two corners 1 more each. With B coarse boundary edges, a
/// triangulation has F = 2 V - B - 2 chi faces; boundary vertices count once, the others twice.
/// A closed component has at least Heawood's count of vertices (4 for a sphere, 7 for a torus), an
/// open one at least one triangle. Combinatorial only: folds and slivers
/// may need more.
int fewest_faces_keeping(const Mesh& m, const Topology& T, const std::vector<char>& edge_feature,
                         const std::vector<char>& corner);

}  // namespace hocurve
