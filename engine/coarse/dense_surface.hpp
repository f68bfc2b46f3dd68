// The smooth surface the dense (fine) mesh defines: its SOLF wedge fits (bands refitted as ruled
// surfaces, as curve_mesh does) and feature-curve fits, and closest-point projection onto it from
// a nearby start face. Coarse lifting snaps its high-order nodes onto this surface.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/planar_patches.hpp"
#include "engine/curving/curve_fit.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/long_edges.hpp"
#include "engine/curving/stencil.hpp"

#include <Eigen/Core>

namespace hocurve {

struct DenseSurfaceOptions {
  int degree = 4;              ///< degree of the dense wedge and curve fits
  FeatureOptions features;     ///< should match the decimation's feature marks
  FitOptions fit;
  bool support = true;         ///< support points when the triangulation is non-uniform (as curve_mesh)
  /// Largest lift from the dense facets onto the fits, in mean edge lengths of the dense face:
  /// longer lifts are scaled down to it. Smooth fits lift by ~h^2 curvature / 8 (0.006 h on a
  /// 12k-triangle sphere); on scans, one-sided fits at noisy creases overshoot up to 0.3 h.
  double max_lift = 0.1;
  PlanarPatchOptions planar;  ///< flat CAD faces stay flat, as in curve_mesh
  LongEdgeOptions long_edges;  ///< faces with an edge the fits do not reach: PN triangles, as in curve_mesh
};

/// The dense mesh with its topology, features, wedges and fits (everything needed to evaluate
/// the fitted surface at a point of a dense face). Holds a pointer to the mesh: keep it alive.
struct DenseSurface {
  const Mesh* mesh = nullptr;
  Topology T;
  Features features;
  Wedges W;
  FitResult fits;
  CurveFitResult curves;
  std::vector<int> planar_anchor;  ///< per face: planar_patch_faces() (>= 0: the face stays flat)
  std::vector<char> long_face;     ///< per face: LongEdgeResult::face (1: its PN triangle)
  LongEdgeOptions long_edges;
  bool support_used = false;
  double max_lift = 0.1;
  double seconds = 0;
};

/// Detects features, builds wedges and fits every wedge and feature curve of `fine`
/// (TBB-parallel, deterministic).
DenseSurface build_dense_surface(const Mesh& fine, const DenseSurfaceOptions& opt = {});

/// A projection onto the dense surface: where on the dense linear mesh (face, barycentric, or
/// feature edge and its parameter), and the lifted point on the fitted surface.
struct DenseProjection {
  int face = -1;
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();
  int edge = -1;                ///< feature edge (curve projections only)
  double t = 0;                 ///< parameter on edge from E(edge,0) to E(edge,1)
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();  ///< closest point on the dense linear mesh
  Eigen::Vector3d lifted = Eigen::Vector3d::Zero();  ///< the same point on the fitted surface
  int steps = 0;                ///< walk steps taken
};

/// Closest point to x on the dense triangles reachable from start_face without crossing a
/// feature edge (greedy walk over the faces of each corner's wedge), lifted onto the fits.
DenseProjection project_to_dense_surface(const DenseSurface& S, int start_face, const Eigen::Vector3d& x,
                                         int max_steps = 100000);

/// Intersection of the line x + t d (d unit) with the dense triangles, found by a point-location
/// walk from start_face (across the edge with the most negative barycentric of the hit of each
/// face's plane), without crossing feature or boundary edges; lifted onto the fits. A smooth
/// direction field makes this map smooth, where closest points on a piecewise-linear surface
/// bunch at convex edges and jump at concave ones. ok = false (and the closest point instead)
/// when the walk leaves the region, cycles, or |t| > max_t.
DenseProjection project_along_dense_surface(const DenseSurface& S, int start_face, const Eigen::Vector3d& x,
                                            const Eigen::Vector3d& d, double max_t, bool& ok,
                                            int max_steps = 2000);

/// Closest point to x on the dense feature curves, found by a walk along feature edges that
/// starts at the feature edges nearest start_face; lifted onto the curve fits. Falls back to
/// project_to_dense_surface when no feature edge is near start_face.
DenseProjection project_to_dense_curve(const DenseSurface& S, int start_face, const Eigen::Vector3d& x,
                                       int max_steps = 100000);

/// Closest point on triangle (a, b, c) to x; barycentric coordinates in out_bary.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                          Eigen::Vector3d& out_bary);

}  // namespace hocurve
