// Quadric-error edge-collapse decimation with feature preservation, building the bijective
// coarse <-> fine map (successive self-parameterization) as it goes.
#pragma once
#include "engine/coarse/multigrid_map.hpp"
#include "engine/core/mesh.hpp"

#include <string>

namespace hocurve {

struct DecimateOptions {
  int target_faces = 0;             ///< stop at this many faces (> 0), else use target_ratio
  double target_ratio = 0.04;       ///< fraction of the input face count, used when target_faces <= 0
  bool preserve_features = true;    ///< feature vertices slide only along their curve, corners stay
  double feature_angle_deg = 35.0;  ///< dihedral angle above which an edge is a feature
  double corner_angle_deg = 35.0;   ///< a feature vertex is a corner when its curve turns more than this
  bool entity_borders = true;       ///< edges between different face entities are features
  /// Open sharp-edge curves with fewer edges than this are ignored: on scanned or organic
  /// surfaces such fragments are noise, and their corners would pin the decimation.
  int min_feature_curve_edges = 4;
  /// Soft open curves (mean dihedral angle below soft_feature_angle_deg) need this many edges:
  /// longer crease fragments of scans also pin the decimation and cost accuracy (bench/LIFT.md).
  int min_soft_curve_edges = 12;
  double soft_feature_angle_deg = 60.0;
  double min_angle_deg = 10.0;      ///< new triangles must keep this smallest 3D angle (or not get worse)
  double max_normal_change_deg = 60.0;  ///< a face's normal may turn at most this much in one collapse
  double uv_min_quality = 0.01;     ///< smallest accepted UV triangle quality in the flattened patches
  bool build_map = true;            ///< record the per-collapse maps and track the fine vertices
  /// With the map: a collapse that would leave a tracked dense vertex further than this (x the
  /// bounding-box diagonal) from the straight coarse faces waits until every other collapse is
  /// done; those that wait go by that distance, smallest first (0: plain quadric order). Why: the
  /// quadric order cuts thin parts (ear tips, fingers) early; the map knows what a collapse costs
  /// the dense surface. Measured (bench_lift, P4 Hausdorff / diagonal at 4% of the faces, 0 ->
  /// 0.01): bunny 1.42 -> 1.04%, armadillo 0.78 -> 0.72%, skull 2.03 -> 1.04%, spot 1.53 -> 1.39%,
  /// and at 2% armadillo 1.58 -> 0.91%; on CAD exports mixed (lever 5.5 -> 4.8%, king 3.9 -> 4.5%).
  /// 0.005 / 0.0075 / 0.015 / 0.02 were each worse than 0.01 on at least two of the four scans.
  double defer_deviation = 0.01;
  /// With the map: collapses after which a tracked dense vertex would be further than this (x the
  /// bounding-box diagonal) from the new straight faces, or the new vertex, its edges' midpoints or
  /// the new faces' centroids further from the input, are refused (0: no limit). The coarse surface
  /// then stays within about this distance of the input even where the target is out of reach.
  /// Why: unreachable targets (CAD exports, whose features pin vertices) used to run every
  /// deferred collapse. Measured (bench_lift, Hausdorff / diagonal of the straight coarse mesh, no
  /// limit -> 0.015, faces, at 4%): hinge 4.61 -> 1.50% (140 -> 212 faces, target 48), lever 5.75
  /// -> 2.30% (428 -> 496), t13 13.1 -> 1.49% (218 -> 434), ktoolcav 5.13 -> 1.46% (1006 -> 1042),
  /// king 6.97 -> 1.48% (3576 -> 3656, target 1280); scans at 4% reach their targets (P4: bunny
  /// 1.04 -> 0.90%, spot 1.39 -> 1.17%, armadillo, skull the same); at 2% bunny stops at 214 faces
  /// (target 132; P4 5.23 -> 1.37%), skull 298 (206; 3.60 -> 1.73%), spot 208 (116; 5.07 -> 1.38%).
  double max_deviation = 0.015;
  /// Per fine vertex, a factor on its quadric (empty: all 1): vertices with a larger weight cost
  /// more to move, so their region keeps more coarse vertices.
  std::vector<double> vertex_weight;
  /// Vertices that never move and are never removed (e.g. FanSplit::pinned: the copies of a
  /// split non-manifold vertex, which must stay together).
  std::vector<int> pinned_vertices;
};

/// Collapses that were attempted and refused, by reason (one edge can be refused several times).
struct RejectCounts {
  long long link = 0;       ///< link condition: the collapse would change the topology
  long long feature = 0;    ///< would move a corner, or a feature vertex off its curve
  long long boundary = 0;   ///< neither an interior edge (two faces) nor one of the open boundary (one)
  long long valence = 0;    ///< a vertex would drop below 3 faces, or the patch is too large
  long long fold = 0;       ///< a face normal would turn more than max_normal_change_deg (3D fold-over)
  long long sliver = 0;     ///< a new triangle would be thinner than min_angle_deg
  long long flatten = 0;    ///< the joint flattening flips, degenerates or overlaps a triangle
  long long deviation = 0;  ///< would move the dense surface further than max_deviation
  long long total() const { return link + feature + boundary + valence + fold + sliver + flatten + deviation; }
};

struct DecimateResult {
  Mesh coarse;                      ///< keeps face entities and physical groups of the input
  CoarseMap map;                    ///< empty when build_map is false
  /// Coarse vertex -> the fine vertex it continues (-1: made by split_coarse_edges).
  std::vector<int> coarse_vertex_origin;
  /// Coarse vertex on a feature curve the decimation kept: it never moved (it sits on its origin).
  std::vector<char> coarse_vertex_feature;
  std::vector<char> coarse_vertex_pinned;  ///< coarse vertex continues a pinned vertex (it never moved)
  int target_faces = 0;
  bool reached_target = false;
  std::string message;              ///< one line: what was reached, and why it stopped
  long long collapses = 0;
  long long deferred = 0;           ///< collapses put off by defer_deviation (each done later or never)
  RejectCounts rejected;
  int feature_edges = 0, corners = 0;
  /// The fewest faces any mesh keeping the input's topology, corners and feature curves can have
  /// (fewest_faces_keeping): a target below it cannot be reached whatever the checks allow.
  int fewest_faces = 0;
  double seconds_total = 0, seconds_flatten = 0, seconds_tracking = 0;
};

/// Cosine of the smallest angle of triangle abc (1 when degenerate): the sliver measure.
double min_angle_cos_max(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Decimates a closed or open, edge- and vertex-manifold triangle mesh by quadric-error edge
/// collapses down to the target face count (or as close as the safety checks allow), and builds
/// the map between the input and the result. Throws InputError on non-manifold input.
DecimateResult decimate(const Mesh& fine, const DecimateOptions& opt = {});

}  // namespace hocurve
