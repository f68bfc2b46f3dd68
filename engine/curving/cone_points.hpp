// Cone points: vertices off the feature curves where the surface has a point singularity (the
// apex of a cone), found by their angle defect.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <vector>

namespace hocurve {

struct ConeOptions {
  /// A vertex is a cone point when its angle defect |2 pi - sum of its face angles| exceeds
  /// min_defect_deg and its defect per area (the discrete Gaussian curvature) is curvature_ratio
  /// times that of each of its neighbours: on a smooth surface, however coarse, the defect per
  /// area varies slowly (a uv sphere's pole and its neighbours: ~1x); at a cone's apex it is
  /// concentrated at the apex (the cone itself is flat: its neighbours' defects are ~0). 4
  /// degrees: cones up to a half-angle of 81 degrees; at 1 degree, 9 vertices of a marching-
  /// tetrahedra sphere (irregular areas) passed the ratio test against the neighbours' median, at
  /// 2 degrees 1, at 4 none. Against every neighbour instead of the median: the scans' noise spikes
  /// and t13's small fillet blends drop out (bunny_closed 11 -> 3, spot 10 -> 2, t13 11 -> 4);
  /// cone meshes and Gmsh's cones (ratio > 40) stay.
  double min_defect_deg = 4.0;
  double curvature_ratio = 8.0;
  /// Blunter cones (defects from min_blunt_defect_deg to min_defect_deg: half-angles of 81-88
  /// degrees) count when, besides the ratio test, the surface also descends from the vertex like a
  /// cone (straight rulings: the 2-ring's slope seen from it is the 1-ring's, where on a smooth
  /// surface it doubles). Measured: P4 on cones of half-angle 84 / 87 degrees was 5.7x worse than
  /// the linear input (the fits round the apex off).
  double min_blunt_defect_deg = 0.25;
  /// And the vertex must stand off the quadric fitted to its 2-ring without it by at least this
  /// fraction of what a regular cone of its defect d would (h sqrt(|d| / pi), h its 1-ring's mean
  /// edge length; the cot of the half-angle for small d): cone meshes of defects 0.45-199 degrees
  /// stand off 0.56-0.67 of that, the false cones of marching-tetrahedra spheres and tori (defects
  /// 0.25-12.8 degrees, passing the ratio test by their irregular areas) at most 0.12, two saddle
  /// points of the armadillo scan 0.03; the CAD exports' cones 0.23 (ktoolcav) to 1.34 (t13).
  double min_apex_miss = 0.2;
};

/// Per vertex, 1 for a cone point. Only vertices off the features (vertex_feature[v] == 0; may
/// be empty) whose faces close a single fan are candidates; their neighbours' curvatures count
/// when they are candidates too.
std::vector<char> cone_points(const Mesh& mesh, const Topology& T, const std::vector<char>& vertex_feature,
                              const ConeOptions& opt = {});

}  // namespace hocurve
