// In-surface untangling: a curved triangle folded because one side follows a feature curve
// (a rim's arc) across its straight-on-the-surface sides gets those free sides bent along,
// within the surface, instead of its curve pulled back to a chord by the validity repair.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/long_edges.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/validity.hpp"

#include <vector>

namespace hocurve {

struct UntangleOptions {
  bool enabled = true;
  /// A patch is the faces to untangle and up to this many rings of faces round them, grown across
  /// non-feature edges; 1, 2, ... rings are tried until every face of the patch clears the floor.
  int max_rings = 3;
  /// A patch is mapped to the plane normal to its faces' mean normal only when every face's normal
  /// is within acos(min_chart_cos) of it (else the plane's map of the patch could fold).
  double min_chart_cos = 0.5;
};

struct UntangleResult {
  long long targets = 0;   ///< faces at or below the threshold after placement (not degenerate)
  long long patches = 0;   ///< patches tried
  long long kept = 0;      ///< patches whose new nodes were kept
  long long cleared = 0;   ///< targets that clear the threshold in the kept patches
  double seconds = 0;
};

/// Where to put a point of the surface for face f at barycentric coordinates xi (xi may leave
/// the face slightly): the same surface the node placement used for it.
struct SurfaceOfFaces {
  const Mesh* mesh = nullptr;
  const Wedges* wedges = nullptr;
  const std::vector<LocalFit>* fits = nullptr;
  const std::vector<int>* planar = nullptr;               ///< per face, >= 0: flat (may be null)
  const std::vector<const LocalFit*>* face_fits = nullptr;  ///< per face, an exact surface (may be null)
  const LongEdgeResult* long_edge = nullptr;                ///< its faces are left alone (may be null)
  Eigen::Vector3d point(int f, const Eigen::Vector3d& xi) const;
  bool frozen(int f) const { return long_edge && !long_edge->face.empty() && long_edge->face[f]; }
};

/// Faces of hm whose min J / J_straight is at or below threshold (validity.quality_floor, or
/// validity.min_scaled_jacobian when that is higher) get a patch round them; in the plane of the
/// patch, each free node (face nodes; nodes of non-feature edges inside the patch) moves by the
/// harmonic extension (P1 Laplacian on the nodes' lattice, stiffer in smaller faces) of the
/// in-plane displacement of the fixed nodes (corners, fixed edges, the patch's rim) and goes
/// back onto the surface (surface.point). A patch is kept only when it has fewer faces below the
/// threshold and no face that cleared it falls below. fixed_edges: per Topology edge, 1 where its
/// nodes stay and patches do not grow across (feature curves; edges on exact surfaces' crossings).
/// checks: receives every face's check at that threshold for hm as left (a patch's rim stays, so
/// only its faces change), for repair_validity's floor_checks; empty when none was made.
UntangleResult untangle_in_surface(const Topology& T, const std::vector<char>& fixed_edges,
                                   const SurfaceOfFaces& surface, const ValidityOptions& validity,
                                   HighOrderMesh& hm, const UntangleOptions& opt = {},
                                   std::vector<ElementValidity>* checks = nullptr);

}  // namespace hocurve
