// Joint conformal (LSCM) flattening of the patch around one edge collapse, before and after,
// onto one planar domain with a shared boundary (Liu et al. 2021, "Surface Multigrid via
// Intrinsic Prolongation", re-implemented from the paper; docs/algorithm.md, section 9).
#pragma once
#include <Eigen/Core>

#include <array>
#include <vector>

namespace hocurve {

/// The patch of one collapse in local numbering: local 0 is the survivor s, local 1 the absorbed
/// vertex r, the others are the ring. Pre faces are all faces incident to s or r; the post faces
/// are the pre faces that do not contain both, with r and s replaced by the post survivor, whose
/// UV is the extra unknown number X.size() (or local 0's own UV when `post_reuses_survivor_uv`,
/// used when s does not move: on the mesh boundary or on a feature curve, so that the boundary
/// or curve through s is the same polyline before and after).
struct CollapsePatch {
  std::vector<Eigen::Vector3d> X;            ///< 3D positions of the local vertices (pre)
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  ///< 3D position of the survivor after the collapse
  std::vector<std::array<int, 3>> faces;     ///< pre faces, local indices, consistently oriented
  std::vector<char> removed;                 ///< per face: contains both s and r (gone after)
  bool post_reuses_survivor_uv = false;  ///< s does not move (p == X[0]): post survivor = local 0's UV
  /// Collapse along a feature curve: local index of r's other curve neighbour. Its UV is held on
  /// the line through s and r, beyond r, so that the curve x - r - s maps onto the post curve
  /// x - s and the map sends curve points to curve points. -1 when unused.
  int curve_pin = -1;
  bool s_interior = true, r_interior = true;  ///< not on the mesh boundary
};

struct FlattenOptions {
  double min_area = 1e-10;     ///< smallest accepted signed UV area (the edge s-r has UV length 1)
  double min_quality = 0.01;   ///< smallest accepted UV triangle quality 4 sqrt(3) A / sum l^2
};

/// Result: uv has X.size()+1 rows (the last is the post survivor). ok=false with `why` when a
/// pre or post triangle flips or degenerates, a star overlaps itself (angle sum > 2 pi), the
/// outer ring self-intersects, the pinned curve neighbour does not lie beyond r, or the solve fails.
struct PatchFlattening {
  std::vector<Eigen::Vector2d> uv;
  bool ok = false;
  const char* why = "";
};

/// Flattens pre and post patch together: one sparse-free quadratic problem, the sum of both
/// patches' LSCM energies with shared ring unknowns; gauge s_pre = (0,0), r_pre = (1,0).
PatchFlattening flatten_collapse(const CollapsePatch& patch, const FlattenOptions& opt = {});

/// Post-collapse local triangle of pre face k: r and s replaced by the post survivor index.
std::array<int, 3> post_triangle(const CollapsePatch& patch, int k);

/// Barycentric coordinates of q in the UV triangle (a,b,c) (not clamped).
Eigen::Vector3d uv_barycentric(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                               const Eigen::Vector2d& c, const Eigen::Vector2d& q);

}  // namespace hocurve
