// Long edges of CAD exports: an extrusion wall or a flat face is triangulated by a few long
// triangles next to narrow fillet strips. The vertex fits at their ends are fitted to the strips
// (their Gaussian weights barely see the far end) and extrapolate along the long edge: t13's
// 48 mm wall strips bulged by 4.4 mm. Where an edge is much longer than the edges around its
// ends and its two end fits disagree about it, the fits know nothing of the surface along it;
// such edges and their faces take the cubic PN triangle of their corners, with normals from the
// faces of their own size. On smooth surfaces graded abruptly the end fits agree (a Gmsh sphere
// jumping from h = 0.2 to 0.025 keeps its P4 error, 5.3e-7; PN faces there gave 1.9e-2).
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"

#include <Eigen/Core>
#include <vector>

namespace hocurve {

struct LongEdgeOptions {
  /// An edge is long when it is longer than ratio x the median length of the edges at one of its
  /// ends (0: none is). Gradual grading (Gmsh meshes of analytic shapes and CAD solids, a torus
  /// graded 5:1, pole fans) never reaches 2; CAD exports have 10-40% such edges.
  double ratio = 2.0;
  /// ... and its end fits disagree about it when one misses the other end, or the two differ at
  /// its midpoint, by more than fit_miss x its length. Measured on long edges: Gmsh spheres graded
  /// 4-10:1 at most 4.3e-5 (ends: 1.7e-8); CAD exports (t13, hinge, king) median 4e-3 to 4e-2.
  double fit_miss = 3e-4;
  /// A face joining a corner of a long face counts for that corner's normal when its area is at
  /// least this fraction of the long face's (faces of its own size, not the fillet strips).
  double same_size_area = 0.25;
  /// A mesh with creases on fewer than this share of its edges and no flat CAD face is a
  /// smooth surface (smooth_surface): its end fits are trusted on every edge. Why: iso-surfaces
  /// (marching tetrahedra) have long edges beside needles whose end fits differ by 3-7e-4 of their
  /// length, and their PN curves left the tori at the linear error (grid 32: 6.9e-3 -> 5.2e-6
  /// without); no per-edge measure separated them from CAD exports' long edges. Feature shares
  /// measured: iso-surface tori 0-0.13%; every shared mesh with long edges placed 1.6-59%. Rims
  /// do not count: a Gmsh hemisphere at h = 0.4 (199 triangles, rim edges 6.7%) placed a long
  /// edge at its pole on a PN triangle, P4 4.3e-2 (linear 4.8e-2).
  double smooth_feature_share = 0.005;
};

struct LongEdgeResult {
  std::vector<char> edge;       ///< per Topology edge: 1 when long (by length alone)
  std::vector<char> unreached;  ///< per edge: long, and its end fits disagree about it
  std::vector<char> face;       ///< per face: 1 when one of its edges is unreached (placed on its PN triangle)
  long long edges = 0, faces = 0;  ///< long edges, faces on their PN triangle
  LongEdgeOptions options;
};

/// Whether the long-edge rule stands down on a mesh (LongEdgeOptions::smooth_feature_share): its
/// feature edges between two faces (creases; an open surface's rim does not count) are few, and
/// `planar` (per face, as planar_patch_faces) has no flat CAD face.
bool smooth_surface(const Features& features, const Topology& T, const std::vector<int>& planar,
                    const LongEdgeOptions& opt);

/// Flags the long edges of mesh, those whose end fits (the corner fits of W, fits) disagree, and
/// their faces. A CAD cylinder's one-row side strips are long, but their ruled band refits agree
/// (the same-size chord normals would flatten the arcs there: 2077x -> 1x). face_fits (per face,
/// face_exact_fits; may be null): an edge of a face on an exact surface is reached, as that
/// surface places it (a Delaunay-meshed filleted box's corner sphere had an edge from a tangent
/// junction, whose fit straddles the junction, placed near its chord: P4 1.1e-2).
LongEdgeResult long_edges(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits,
                          const LongEdgeOptions& opt = {}, const std::vector<const LocalFit*>* face_fits = nullptr);

/// Point at barycentric xi of the cubic PN triangle (Vlachos et al. 2001) with corners P.row(j)
/// and unit normals N.row(j): its edges are the cubic Hermite curves whose end tangents are
/// perpendicular to the end normals (straight where both normals are perpendicular to the edge).
Eigen::Vector3d pn_triangle_point(const Eigen::Matrix3d& P, const Eigen::Matrix3d& N, const Eigen::Vector3d& xi);

/// Corner normals of face f at its own size: at each corner, the area-weighted normal of f and
/// of the faces of that corner's wedge that share an edge with f and have at least
/// opt.same_size_area x f's area (rows: corners).
Eigen::Matrix3d same_size_normals(const Mesh& mesh, const Wedges& W, int f, const LongEdgeOptions& opt);

/// pn_triangle_point of face f with its same_size_normals.
Eigen::Vector3d long_face_point(const Mesh& mesh, const Wedges& W, int f, const Eigen::Vector3d& xi,
                                const LongEdgeOptions& opt);

}  // namespace hocurve
