// Choosing, region by region, the one of several valid placements of a coarse curved mesh that
// stays closest to the dense input.
//
// Why: an element that the snap onto the dense surface folds can be made valid in several ways
// (its nodes back toward the coarse-fit blend, or slid along the dense surface toward their
// straight positions), and which one loses least depends on the element: measured at 4% on the
// shared meshes, each way wins on some meshes and loses on others. The placements differ only
// in clusters of elements around the folded ones, so each cluster can take its own best one.
#pragma once
#include "engine/coarse/multigrid_map.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/core/mesh.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

struct ClosestCandidateResult {
  int clusters = 0;                 ///< connected groups of elements where the candidates differ
  std::vector<int> chosen;          ///< per candidate: clusters that took it
  long long elements_changed = 0;   ///< elements taken from a candidate other than the first
};

/// Merges `candidates` (same order, topology and corners; each valid) into `out`: elements whose
/// nodes agree in every candidate stay as they are; the others are grouped into clusters
/// connected through edges whose nodes differ (so a cluster's boundary edges agree, and any
/// choice per cluster conforms), and each cluster takes the candidate with the smallest largest
/// distance, both ways, between its elements (sampled at the degree-`samples` lattice) and the
/// dense mesh `fine` (grid built on it; the dense vertices that `map` puts in the cluster's
/// elements). Ties go to the earlier candidate. TBB-parallel over clusters.
ClosestCandidateResult choose_closest_candidate(const std::vector<HighOrderMesh>& candidates, const Mesh& fine,
                                                const TriangleGrid& fine_grid, const CoarseMap& map,
                                                HighOrderMesh& out, int samples = 8);

}  // namespace hocurve
