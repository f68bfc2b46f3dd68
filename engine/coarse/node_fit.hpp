// Least-squares fit of a coarse curved mesh's high-order nodes to the dense surface.
//
// Why: nodes snapped onto the dense surface make each coarse element interpolate it, and a
// coarse P4 triangle spanning a strongly curved region then strays from the surface between its
// nodes (measured, bunny at 4%: every node within 0.23% of the diagonal, the element surface
// 0.97% off). Moving the nodes off the surface, each along its own normal, so that the element
// surface is closest to the dense mesh in the least-squares sense both ways (element samples ->
// dense mesh, dense vertices -> element) spreads that error over the element. Moves along the
// surface normal leave the in-plane node layout, and so the Jacobian, nearly as it was.
#pragma once
#include "engine/coarse/multigrid_map.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/core/mesh.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

struct NodeFitOptions {
  int iterations = 3;      ///< Gauss-Newton rounds (closest points found again each round)
  int sample_degree = 8;   ///< element samples: the barycentric lattice of this degree
  /// Tikhonov weight on each node's move, relative to the mean diagonal of the normal equations:
  /// keeps nodes that few samples see (and sliver elements) where they are.
  double damping = 1e-2;
  /// A node moves at most this many times its element's mean straight edge length / order.
  double max_move = 0.5;
};

struct NodeFitResult {
  long long free_nodes = 0;
  double rms_before = 0, rms_after = 0;  ///< RMS residual over all samples (absolute units)
  double seconds = 0;
};

/// Moves the high-order nodes of hm that are not fixed (fixed_node: per global node index of
/// element_node_indices; corners are always fixed) along the curved surface's normal at the
/// node, minimising the squared distances of element samples to the dense mesh `fine` (closest
/// points through `grid`, built on fine) and of the dense vertices to the elements (each starts
/// at the map's (coarse face, barycentric) and is projected onto that element). Equispaced
/// nodes only (hm.distribution); otherwise hm is left as it is. TBB-parallel.
NodeFitResult fit_nodes_to_dense(HighOrderMesh& hm, const Mesh& fine, const TriangleGrid& grid, const CoarseMap& map,
                                 const std::vector<char>& fixed_node, const NodeFitOptions& opt = {});

}  // namespace hocurve
