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
};

/// Distance from feature vertices (distance 0) over the surface.
DistanceField feature_distance(const Mesh& mesh, const Topology& T, const Features& features,
                               const DistanceOptions& opt = {});

}  // namespace hocurve
