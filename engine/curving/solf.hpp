// The SOLF curving pipeline: topology -> features -> feature distance -> uniformity ->
// support points -> local fits per wedge and per feature curve -> node placement -> validity
// repair. Every stage reports its figures and its seconds.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/curving/curve_fit.hpp"
#include "engine/curving/distance_field.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/long_edges.hpp"
#include "engine/curving/offset_bound.hpp"
#include "engine/curving/planar_patches.hpp"
#include "engine/curving/surface_model.hpp"
#include "engine/curving/support_points.hpp"
#include "engine/curving/uniformity.hpp"
#include "engine/curving/untangle.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/validity.hpp"

#include <functional>
#include <string>

namespace hocurve {

/// Auto: decided by the uniformity check (support points only for non-uniform meshes).
enum class Tristate { Auto, On, Off };

struct CurveOptions {
  int order = 4;                                   ///< 1..6
  NodeDistribution distribution = NodeDistribution::Equispaced;
  enum class Method { Solf, Linear } method = Method::Solf;
  FeatureOptions features;
  DistanceOptions distance;
  UniformityOptions uniformity;
  SupportOptions support;
  FitOptions fit;
  PlanarPatchOptions planar;                       ///< flat CAD faces keep their nodes on their plane
  OffsetBoundOptions offset_bound;                 ///< offsets their own fits' tangent planes contradict scaled down
  LongEdgeOptions long_edges;                      ///< faces with an edge the fits do not reach: PN triangles
  ValidityOptions validity;
  UntangleOptions untangle;                        ///< before the repair: folded faces' free nodes bent within the surface
  Tristate use_support = Tristate::Auto;
  bool repair = true;                              ///< run repair_validity (else only check)
  /// Called on the calling thread between stages with the stage name and the overall fraction done.
  std::function<void(const std::string& stage, double fraction)> progress;
};

/// Deviation of the curved surface from the input: high-order node offsets from their
/// positions on the straight triangles.
struct Deviation {
  double max = 0, rms = 0;
  double bbox_diagonal = 0;
  double max_relative = 0, rms_relative = 0;  ///< over the bounding-box diagonal
  /// The same for the offsets' parts along the normals of the node's straight triangles (an edge
  /// node: the smaller over its two): how far the curved surface leaves the input's facets. A
  /// node moved along the surface (untangled, or following a curve side) raises max, not this.
  double normal_max = 0, normal_rms = 0;
  double normal_max_relative = 0, normal_rms_relative = 0;
};

struct CurveResult {
  HighOrderMesh mesh;
  std::string method;
  int vertices = 0, faces = 0, edges = 0;
  double topology_seconds = 0;
  Features features;
  double features_seconds = 0;
  DistanceField distance;
  double distance_seconds = 0;
  Uniformity uniformity;
  double uniformity_seconds = 0;
  bool support_used = false;
  long long support_points = 0;
  double support_seconds = 0;
  long long wedges = 0;
  long long band_wedges = 0;      ///< wedges in one-triangle bands between feature curves (ruled fits)
  FitResult fits;                 ///< per-wedge fits (the fits vector itself is kept for callers)
  CurveFitResult curve_fits;
  long long curve_edges = 0;
  long long face_exact_fits = 0;  ///< faces placed on a neighbour's exact fit (face_exact_fits)
  long long crossing_edges = 0;   ///< edges off the feature curves placed where their faces' exact surfaces cross
  bool smooth_surface = false;    ///< too few features and no flat face: the long-edge rule skipped (smooth_surface)
  long long long_edges = 0;       ///< edges much longer than those around their ends (LongEdgeOptions)
  long long long_edges_placed = 0;  ///< of them, whose end fits disagree: placed on a PN curve (off feature curves)
  long long long_faces = 0;       ///< faces with such an edge: their interior nodes are on their PN triangle
  PlanarPatchResult planar;
  OffsetBoundResult offset_bound;
  std::vector<SurfaceModel> wedge_models;  ///< per wedge: its fit's model
  std::vector<SurfaceModel> face_models;   ///< per face: the model that placed its nodes last
  double placement_seconds = 0;
  UntangleResult untangle;
  ValidityReport validity;
  double validity_seconds = 0;
  Deviation deviation;
  double total_seconds = 0;
};

/// Curves a linear triangle mesh to order opt.order. Throws UsageError for an order outside
/// 1..6, InputError for an empty mesh.
CurveResult curve_mesh(const Mesh& mesh, const CurveOptions& opt = {});

/// Offsets of hm's high-order nodes from the straight triangles of mesh.
Deviation measure_deviation(const Mesh& mesh, const HighOrderMesh& hm);

}  // namespace hocurve
