// Refining a lifted coarse mesh where it strays from the dense input: the elements further from
// it than a tolerance are split by longest-edge bisection (split_coarse_edges), and the mesh is
// lifted again, until every element is within the tolerance or a face budget is spent.
//
// Why: the decimation sizes coarse triangles for a linear surface (quadric error), but a curved
// element's error is its interpolation error over the element: a few large elements on strongly
// curved parts (ears, limbs) decide the Hausdorff distance while the rest are far within it
// (bench/LIFT.md "Refining where the curved mesh strays").
#pragma once
#include "engine/coarse/lift.hpp"
#include "engine/coarse/split_edges.hpp"

#include <string>

namespace hocurve {

struct RefineOptions {
  /// Target: every element within this x the input's bounding-box diagonal, both ways
  /// (element_deviation). <= 0: no refinement.
  double tolerance = 0.005;
  int max_faces = 0;   ///< never split beyond this many coarse faces (0: the input's face count)
  int max_rounds = 8;  ///< split-and-lift rounds
  SplitOptions split;
};

struct RefineResult {
  LiftResult lift;  ///< of the final coarse mesh (dec.coarse)
  int rounds = 0, splits = 0, refused = 0;
  int faces_before = 0;
  double deviation_before = 0, deviation_after = 0;  ///< largest element deviation / diagonal
  bool reached = false;  ///< every element within the tolerance
  std::string message;   ///< one line: what was reached, and why it stopped
  double seconds_measure = 0, seconds_split = 0, seconds_lift = 0;
};

/// Lifts dec's coarse mesh (lift_coarse), then refines it: while some element deviates more than
/// the tolerance, every such element is split through the terminal edge of its longest-edge path
/// (split_coarse_edges; an edge on a feature curve too: its new vertex lands on the dense curve),
/// and the mesh is lifted again; of the rounds, the one closest to the input is kept. dec (coarse
/// mesh and map) is updated in place. lopt.progress sees the first lifting's stages,
/// then ("refine round k", 1.0) before each round. dense: the dense surface
/// (build_dense_surface(fine, dense_surface_options(lopt))), built here if null; lifted: dec's
/// lifting if already done (moved from).
RefineResult lift_and_refine(const Mesh& fine, DecimateResult& dec, const LiftOptions& lopt,
                             const RefineOptions& opt = {}, const DenseSurface* dense = nullptr,
                             LiftResult* lifted = nullptr);

}  // namespace hocurve
