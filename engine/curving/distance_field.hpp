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
/// opposite edge (upwind test); obtuse corners also get virtual triangles by unfolding the
/// neighbouring faces (Kimmel-Sethian), and edge updates are always tried. The result is never
/// above Dijkstra's (edge paths only). Exact for a straight feature on a flat mesh up to the few
/// vertices whose characteristic arrives through a later-accepted neighbour.
/// Deterministic (ties broken by vertex index). Throws InputError if T or features belong
/// to another mesh.
DistanceField feature_distance(const Mesh& mesh, const Topology& T, const Features& features,
                               const DistanceOptions& opt = {});

}  // namespace hocurve
