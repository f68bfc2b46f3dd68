// How uniform the triangulation is: edge-length and area statistics and a verdict that
// decides whether the local fits need support points.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <string>
#include <vector>

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
  Spread edge_length, area;
  Spread aspect;                     ///< longest edge / shortest altitude (2/sqrt(3) when equilateral)
  double needle_share = 0;           ///< share of faces with aspect > needle_aspect (zero-area faces count); drives the verdict
  /// Normalised aspect ratio longest edge / (2 sqrt(3) inradius), 1 when equilateral (the
  /// measure of the shared MANIFEST.tsv frac_aspect_gt10 column, and of many mesh generators).
  Spread aspect_normalized;
  double needle_share_normalized = 0;  ///< share of faces with aspect_normalized > needle_aspect (zero-area count)
  long long degenerate_faces = 0;    ///< zero-area faces (not in the aspect spread)
  bool uniform = true;
  std::string reason;  ///< why it is not uniform (empty when uniform)
};

/// min, mean, max, coefficient of variation (population std / mean) and the 1st/99th
/// percentiles (linear interpolation between order statistics) of x.
Spread spread_of(std::vector<double> x);

/// Edge-length (unique edges), area and aspect statistics and the uniformity verdict:
/// non-uniform when edge p99/p1 > max_edge_ratio or needle share > max_needle_share.
Uniformity check_uniformity(const Mesh& mesh, const Topology& T, const UniformityOptions& opt = {});

}  // namespace hocurve
