// Do no harm: curved nodes must agree with their own fits' tangent planes.
//
// A curve on a smooth surface leaves its chord, along the surface's normal, by about L/4 times
// the sine of the angle between the chord and the tangent planes at its ends (a circular arc of
// chord L at angle phi to them: (L/2) tan(phi/2)); a surface patch leaves the plane of a triangle
// of diameter D by about D/4 times the sine of its corners' tilt against that plane. Where the
// placed nodes leave the straight element by much more than their own corner fits' tangent
// planes allow, the fits contradict themselves: a stencil that reached onto another CAD face, a
// curve fit extrapolating past a coarse corner. There the element can end farther from the
// surface than its straight self, so its offsets are scaled down to the bound; flat corners
// (tangent planes containing the element) keep it flat. The tilt is the fits' own: the input mesh's
// (its faces' normals round each corner) is too coarse a measure of it (a torus at h = 0.1 and a
// CAD screw at diag/40: P4 6.8e-7 -> 1.4e-3 and 3.3e-4 -> 6.6e-2 with the smaller of the two).
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

struct OffsetBoundOptions {
  bool enabled = true;
  /// Allowed offset: factor x the circular-arc estimate (L/4 x the largest sine at the ends).
  /// Why not 1: the curvature may change along an edge (a curve flat at one end, curved at the
  /// other leaves its chord by 0.67 of the estimate) and fitted normals carry their own error.
  double factor = 2.0;
  /// Offsets below slack x the edge length (face: its longest edge) are always allowed.
  double slack = 1e-3;
};

struct OffsetBoundResult {
  long long edges = 0;     ///< edges whose offsets were scaled down
  long long faces = 0;     ///< faces whose interior offsets were scaled down
  double min_scale = 1;    ///< smallest scale applied
  std::vector<char> face;  ///< per face: 1 where its interior or one of its edges was scaled
};

/// Unit normal of each wedge's fitted surface at its vertex (#wedges; zero where not bounded: a
/// cone model's apex, an exact surface).
std::vector<Eigen::Vector3d> wedge_normals(const Wedges& W, const std::vector<LocalFit>& fits);


/// Scales the offsets (from the straight positions) of hm's edge and face nodes down to the bound
/// above, per edge and per face (a face's interior by at most its edges' scale too), so the mesh
/// stays conforming. What exact surfaces placed is left alone: faces on one (face_fits, may be
/// null), their edges, and corners whose fit is one. Deterministic and thread-count independent.
OffsetBoundResult bound_offsets(const Mesh& mesh, const Topology& T, const Wedges& W,
                                const std::vector<LocalFit>& fits, const std::vector<const LocalFit*>* face_fits,
                                HighOrderMesh& hm, const OffsetBoundOptions& opt = {});

}  // namespace hocurve
