// The volume pipeline: closed shells -> dense curving of the surface (curve_mesh, unchanged)
// -> linear tets keeping the surface's triangles (Gmsh) -> order-p tets with the curved
// boundary nodes -> untangling/optimization with the boundary fixed -> certified validity.
// Not thread-safe: the Gmsh stage uses Gmsh's process-global state (gmsh_tets.hpp).
#pragma once
#include "engine/curving/solf.hpp"
#include "engine/volume/gmsh_tets.hpp"
#include "engine/volume/optimize_tets.hpp"
#include "engine/volume/smooth_interior.hpp"
#include "engine/volume/tet_jacobian.hpp"
#include "engine/volume/tet_mesh.hpp"

#include <vector>

namespace hocurve {

struct VolumeOptions {
  CurveOptions curve;        ///< the surface, exactly as `hocurve curve` makes it (order 1..6, equispaced)
  LinearTetOptions tets;
  SmoothOptions smooth;
  /// Smoothed: the tets whose certified min det J / max det J is below this once the boundary is
  /// curved (and rings around). Why not only the invalid ones: on the h = 0.35 sphere, smoothing
  /// every tet raised the P4 min from 0.44 to 0.62 at no risk.
  double smooth_below = 0.5;
  TetOptimizeOptions optimize;
  bool optimize_enabled = true;  ///< smooth_interior, then optimize_tets
  TetCheckOptions check;
};

/// Per-tet certified figures of a whole mesh.
struct TetMeshQuality {
  long long tets = 0, invalid = 0;
  double min_scaled_jacobian = 0;  ///< min over tets of the certified min det J / max det J
  double p1_scaled_jacobian = 0;   ///< its 1st percentile
  double sampled_min_scaled_jacobian = 0, sampled_p1_scaled_jacobian = 0;  ///< the same from samples (as Gmsh)
  double min_ratio = 0;            ///< min over tets of the certified min det J / det J_straight
  std::vector<int> invalid_tets;
  std::vector<double> scaled_jacobian;  ///< #T, each tet's certified min det J / max det J
};

struct VolumeResult {
  CurveResult curve;          ///< the curved surface (curve.mesh is `hocurve curve`'s output)
  TetMesh mesh;
  int shells = 0;
  long long linear_tets = 0;     ///< Gmsh's tets
  long long split_edges = 0;     ///< inside edges of cap tets split (split_cap_tets)
  long long invalid_before = 0;  ///< tets invalid (certified) right after the boundary was imposed
  TetOptimizeResult optimize;
  TetMeshQuality quality;        ///< final, certified
  double shells_seconds = 0, curve_seconds = 0, tets_seconds = 0, elevate_seconds = 0,
         check_before_seconds = 0, smooth_seconds = 0, check_seconds = 0, total_seconds = 0;
};

/// Certifies every tet of tm (TBB-parallel, deterministic).
TetMeshQuality check_tet_mesh(const TetMesh& tm, const TetJacobianBasis& basis, const TetCheckOptions& opt = {});

/// Runs the pipeline on a closed surface. Throws InputError for an open, non-manifold or
/// self-intersecting surface (naming where) before writing anything, UsageError for an order
/// outside 1..4 or Lobatto nodes.
VolumeResult volume_mesh(const Mesh& surface, const VolumeOptions& opt = {});

}  // namespace hocurve
