// The bijective map between a dense surface and its decimated (coarse) version, as the
// composition of one piecewise-linear map per edge collapse (successive self-parameterization).
//
// How queries work, and why:
// - Every collapse stores the joint flattening of its patch (pre and post triangles share the
//   outer ring, so "same UV point" is a PL bijection between the two patches).
// - The fine vertices are pushed through every collapse while decimating (eager tracking), so
//   the table "fine vertex -> (coarse face, barycentric)" and its inverse "coarse face -> fine
//   vertices" cost nothing to query (fits gather their points from it).
// - Arbitrary points are replayed through the stored records: forward (fine -> coarse) visits
//   only the collapses whose patch contains the current face (per-face sorted record lists,
//   binary search), backward (coarse -> fine) the same in reverse, post UVs -> pre UVs. The
//   position returned by coarse_to_fine is interpolated on the fine mesh itself, so it lies on the
//   dense surface exactly.
// - Point location picks the triangle with the largest smallest barycentric, clamps and
//   renormalises; clamps beyond 1e-12 are counted (MapQueryStats). On the test meshes no clamp
//   occurs and round trips close to ~1e-15 of the bounding-box diagonal.
#pragma once
#include "engine/core/mesh.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <vector>

namespace hocurve {

/// A point on a triangle mesh: face, barycentric coordinates (>= 0, sum 1) and 3D position.
struct SurfacePoint {
  int face = -1;
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

/// Per-collapse records plus the fine-vertex -> coarse-point table. Face ids inside the records
/// are fine face ids: a face keeps its id while it survives, so the coarse faces are the
/// surviving fine ids (coarse_face_id) renumbered.
struct CoarseMap {
  Eigen::MatrixXd fine_V, coarse_V;
  Eigen::MatrixXi fine_F, coarse_F;
  std::vector<int> coarse_face_id;   ///< coarse face -> fine face id it continues
  std::vector<int> face_to_coarse;   ///< fine face id -> coarse face, -1 if collapsed away

  // --- collapse records, in collapse order (CSR) ---
  std::vector<int> rec_uv_start;     ///< record c: uv[rec_uv_start[c] ..] (n pre + 1 post survivor)
  std::vector<Eigen::Vector2d> rec_uv;
  std::vector<int> rec_face_start;   ///< record c: faces rec_face_start[c] .. [c+1]
  std::vector<int> rec_face;         ///< fine face id
  std::vector<std::array<std::uint8_t, 3>> rec_face_local;  ///< pre triangle, local indices
  std::vector<char> rec_face_removed;
  std::vector<char> rec_post_reuses; ///< per record: post survivor uses local 0's UV
  std::vector<std::array<int, 2>> rec_edge;  ///< per record: (survivor, absorbed) fine vertex ids

  /// Fine face id -> the records whose pre patch contains it, increasing (CSR).
  std::vector<int> face_rec_start, face_rec;

  // --- every fine vertex on the coarse mesh ---
  std::vector<int> vertex_coarse_face;  ///< per fine vertex
  Eigen::MatrixXd vertex_coarse_bary;   ///< #V_fine x 3
  /// Coarse face -> fine vertices mapped into it (CSR), for gathering MLS fit points.
  std::vector<int> cf_start, cf_vertices;

  // --- edge splits after the decimation (split_coarse_edges); both empty when there are none ---
  /// Per coarse face: its barycentrics -> barycentrics on the decimated face it lies in (the
  /// collapse records know only those; coarse_face_id names its fine id).
  std::vector<Eigen::Matrix3d> split_to_base;
  /// Per coarse face: the next coarse face inside the same decimated face, -1 after the last
  /// (face_to_coarse names the first).
  std::vector<int> split_next;

  int num_collapses() const { return static_cast<int>(rec_edge.size()); }
  /// The fine vertices whose image lies in coarse face f.
  std::pair<const int*, const int*> fine_vertices_in(int coarse_face) const {
    return {cf_vertices.data() + cf_start[coarse_face], cf_vertices.data() + cf_start[coarse_face + 1]};
  }
};

/// Counters of one batch of queries: point location fell outside every candidate triangle by
/// more than the tolerance and was clamped to the nearest one.
struct MapQueryStats {
  long long steps = 0, clamped = 0;
  double worst_outside = 0;  ///< most negative barycentric seen before clamping (as a positive number)
};

/// Rebuilds cf_start / cf_vertices from vertex_coarse_face (#coarse faces from coarse_F).
void index_fine_vertices(CoarseMap& map);

/// Maps a point of the fine mesh (fine face, barycentric) onto the coarse mesh by replaying the
/// collapses that touch it in order.
SurfacePoint fine_to_coarse(const CoarseMap& map, int fine_face, const Eigen::Vector3d& bary,
                            MapQueryStats* stats = nullptr);

/// Maps a point of the coarse mesh (coarse face, barycentric) onto the dense surface by replaying
/// the collapses in reverse order (post layout -> pre layout). Returns the fine face, its
/// barycentrics and the position on the dense surface.
SurfacePoint coarse_to_fine(const CoarseMap& map, int coarse_face, const Eigen::Vector3d& bary,
                            MapQueryStats* stats = nullptr);

/// Position on the coarse mesh of every fine vertex (#V_fine x 3).
Eigen::MatrixXd fine_vertices_on_coarse(const CoarseMap& map);

/// Prolongation matrix P (#V_fine x #V_coarse): row i holds the barycentric weights of fine
/// vertex i in its coarse triangle, so P * coarse_V = fine_vertices_on_coarse(map).
Eigen::SparseMatrix<double> prolongation(const CoarseMap& map);

/// Locates q among the UV triangles tris (local indices into uv): the triangle whose smallest
/// barycentric is largest; negatives beyond -tol are clamped and counted. Returns the index.
int locate_uv(const Eigen::Vector2d* uv, const std::array<int, 3>* tris, int ntris, const Eigen::Vector2d& q,
              Eigen::Vector3d& bary, MapQueryStats* stats, double tol = 1e-12);

}  // namespace hocurve
