// Geodesic distance from the feature curves to every vertex; it sizes the fitting stencils.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"

#include <Eigen/Core>

namespace hocurve {

struct DistanceOptions {
  bool fast_marching = true;  ///< false: Dijkstra along edges (an upper bound of the geodesic distance)
};

struct DistanceField {
  Eigen::VectorXd distance;   ///< per vertex; +infinity where no feature is reachable (no features at all)
  double max_finite = 0.0;
  long long sources = 0;      ///< feature vertices (distance 0)
  long long unreachable = 0;  ///< vertices left at +infinity (no feature on their component)
};

/// Distance from feature vertices (distance 0) over the surface. Fast marching uses the
/// first-order planar-front update in each triangle whose characteristic enters through the
/// opposite edge (upwind test), else edge updates; Dijkstra uses edge updates only.
/// Deterministic (ties broken by vertex index).
DistanceField feature_distance(const Mesh& mesh, const Topology& T, const Features& features,
                               const DistanceOptions& opt = {});

}  // namespace hocurve
