// Splitting coarse edges after the decimation, with the coarse <-> fine map kept a bijection
// (the tool of refine_coarse).
#pragma once
#include "engine/coarse/decimate.hpp"

#include <array>
#include <vector>

namespace hocurve {

struct SplitOptions {
  /// A new face's normal may turn at most this much from its parent's. Why not the decimation's
  /// 60: on strongly curved parts the straight parent is itself far from the surface's normals;
  /// measured (bench_lift, armadillo at 3% / 4%, tolerance 0.5%, cap 5%): 60 and 70 stop at
  /// 0.745% / 0.650%, 80 and 89 reach 0.491% / 0.481%; bunny, spot and skull the same for all.
  double max_normal_change_deg = 80.0;
  double min_angle_deg = 5.0;           ///< new faces keep this smallest angle (or half their parent's)
};

struct SplitResult {
  int split = 0, refused = 0;  ///< edges split, and edges that may not split
  std::vector<int> faces;      ///< the faces split (each keeps its id for one of its parts)
  std::vector<std::array<int, 3>> vertices;  ///< per split: (a, b, new vertex)
};

/// Splits coarse edges (a, b) of dec.coarse at their midpoints in the map's parametrization (or at
/// 0.4, 0.6, 0.3, 0.7 of them when the midpoint's parts would fold): the new vertex is the point of
/// the dense surface that the map sends that point to, each face of the edge (two, or one on the
/// open boundary) becomes two, and every fine vertex of those faces moves to the part that holds
/// it, so the map stays a bijection. The new vertices continue no fine vertex (coarse_vertex_origin
/// -1) and are not feature vertices until the caller marks them (on an edge along a dense feature
/// curve, entity border or the open boundary, the map puts them on that curve). An edge may split
/// when neither face was split in this call, and when no part would fold (turn its normal more
/// than max_normal_change_deg) or be thinner than both min_angle_deg and half its face's smallest
/// angle. Needs dec.map.
SplitResult split_coarse_edges(DecimateResult& dec, const std::vector<std::array<int, 2>>& edges,
                               const SplitOptions& opt = {});

}  // namespace hocurve
