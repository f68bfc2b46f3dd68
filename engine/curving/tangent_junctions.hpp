// Tangent junctions: curves where the surface is smooth to first order but its curvature jumps
// (a fillet meeting a plane or a corner sphere, a cylinder meeting a tangent plane). Their
// dihedral angles are those of the smooth surface around them, so no angle test finds them, yet
// a fit across one cannot follow both sides.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/stencil.hpp"

#include <vector>

namespace hocurve {

/// Fit of the surface around one interior edge: a Gaussian-weighted least-squares cubic height
/// function z(x, y) (x along the edge, y across it, z along its faces' mean normal, lengths over
/// the edge length h), with and without the terms y+^2 and x y+^2 (y+ = max(y, 0)) that let the
/// second derivative across the edge line jump there.
struct CurvatureJump {
  bool determined = false;  ///< enough points, and the jump terms not combinations of the cubic's
  double jump = 0;          ///< |jump of z_yy| at the edge midpoint, in 1/h (= curvature jump x h)
  double residual_ratio = 1;  ///< weighted RMS residual with the jump terms / without them
};

/// Working memory of curvature_jump (one per thread); results never depend on it.
struct JumpScratch {
  std::vector<int> faces, vertices;
  StampSet seen;
};

/// The fit above for edge e, on the vertices of three face rings around it grown without
/// crossing the edges marked in `wall` (edge_region_vertices), Gaussian weights of width one
/// edge length.
CurvatureJump curvature_jump(const Mesh& mesh, const Topology& T, const std::vector<char>& wall, int e,
                             JumpScratch& scratch);

/// FeatureOptions::tangent_junctions: per edge, 1 where it is a junction edge (none inside one
/// exact quadric, with FeatureOptions::exact_quadrics: edge_on_exact_quadric with walls at angle_deg). `wall`: the
/// features found so far (not tested, and stencils do not cross them); `theta`: per edge, its
/// dihedral angle in degrees.
std::vector<char> tangent_junction_edges(const Mesh& mesh, const Topology& T, const std::vector<char>& wall,
                                         const std::vector<double>& theta, const FeatureOptions& opt);

}  // namespace hocurve
