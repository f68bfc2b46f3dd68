// How uniform the triangulation is: edge-length and area statistics and a verdict that
// decides whether the local fits need support points.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <string>

namespace hocurve {

struct UniformityOptions {
  double max_edge_ratio = 8.0;     ///< p99/p1 edge length above this -> non-uniform
  double max_needle_share = 0.01;  ///< share of needle triangles above this -> non-uniform
  double needle_aspect = 10.0;     ///< longest edge / shortest altitude ratio that makes a needle
};

/// Distribution summary of a positive quantity.
struct Spread {
  double min = 0, mean = 0, max = 0, cv = 0, p1 = 0, p99 = 0;
  double ratio_p99_p1() const { return p1 > 0 ? p99 / p1 : 0; }
};

struct Uniformity {
  Spread edge_length, area, aspect;
  double needle_share = 0;
  bool uniform = true;
  std::string reason;  ///< why it is not uniform (empty when uniform)
};

/// Edge-length, area and aspect statistics and the uniformity verdict.
Uniformity check_uniformity(const Mesh& mesh, const Topology& T, const UniformityOptions& opt = {});

}  // namespace hocurve
