// Needles whose corners nearly meet (marching tetrahedra and marching cubes put vertices 1e-5 of
// an edge apart): the triangle is its two long edges, nearly one segment. Curved independently
// (each from its own corners' fits) the two long edges differ by the fits' error, which exceeds
// the needle's width, and cross: the element folds, and the repair straightened it together
// with the long edges it shares with regular neighbours. Aligned, the long edges of a bundle run
// parallel to one curve, offset by the corners' own offsets: the needle keeps the sign of its
// straight Jacobian, and its neighbours their curvature.
#pragma once
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

/// Faces of hm that are needles: shortest edge below short_ratio x longest (0: none).
std::vector<int> needle_faces(const HighOrderMesh& hm, const std::vector<int>& faces, double short_ratio);

/// Aligns the listed needles of hm: their long edges are joined into bundles (edges of one
/// needle, transitively); in each bundle the lowest-numbered edge is the master and every other
/// edge becomes the master's curve moved by the linear interpolation of its ends' offsets from the
/// master's nearer ends. Each needle's short edge goes straight and its face nodes follow the
/// master's curve in the same way. Bundles with an end further than max_offset x the master's
/// length from the master's are left alone. Returns the number of edges moved.
long long align_needles(HighOrderMesh& hm, const std::vector<int>& needles, double max_offset);

}  // namespace hocurve
