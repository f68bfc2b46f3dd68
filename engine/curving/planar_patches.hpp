// Planar faces of CAD exports: a flat CAD face is triangulated by a few large, exactly coplanar
// triangles, bordered by much smaller ones where a fillet starts. The vertex fits at its corners
// follow the fillet (a polynomial cannot turn from a plane into a fillet) and bend the flat face.
// Such patches are recognised by exact coplanarity plus that size contrast, and their high-order
// nodes are put back on their plane.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

struct PlanarPatchOptions {
  bool enabled = true;
  /// Faces joined by an edge whose dihedral angle is below this (radians) are coplanar. Float32 CAD
  /// exports are coplanar to ~1e-6 (the shared CAD meshes keep their patches and deviations at
  /// 1e-6). Curved meshes have such pairs only by chance: a marching-tetrahedra sphere (12,868
  /// triangles) had one quad at 5.3e-5 among slivers 6x smaller, flattened 1.7e-3 off the sphere
  /// (P4 elsewhere: 7e-6) with 1e-4.
  double coplanar_angle = 1e-5;
  /// A patch of at least two coplanar faces qualifies when its smallest face is at least this many
  /// times larger than every face bordering it. Why: the strips of a CAD cylinder are planar
  /// pairs too, but bordered by strips of their own size.
  double area_ratio = 4.0;
  /// A patch also qualifies when it holds a vertex whose whole star is in it (every edge around the
  /// vertex coplanar): a flat CAD face meshed with interior vertices, as Gmsh meshes it, whose
  /// border with a fillet or a tangent cylinder has no size contrast. A cylinder's strips are
  /// coplanar pairs without such a vertex; a curved surface is coplanar that widely only by chance.
  bool whole_star = true;
};

struct PlanarPatchResult {
  long long patches = 0;   ///< qualifying patches
  long long faces = 0;     ///< their faces
  double max_move = 0;     ///< largest node move onto a plane
};

/// Per face: the largest face of its qualifying planar patch (its plane), or -1. With
/// `edge_feature` (per edge, as Features::edge_feature) a patch also qualifies when every edge
/// bordering it is a feature: a whole flat face between feature curves, such as a chamfer strip two
/// triangles wide, whose corners' one-sided fits are not exactly planar (float32 noise, a 45 degree
/// box chamfer: P4 nodes 4e-7 off, the input 4e-8).
std::vector<int> planar_patch_faces(const Mesh& mesh, const Topology& T, const PlanarPatchOptions& opt = {},
                                    const std::vector<char>* edge_feature = nullptr);

/// Projects the high-order nodes of every qualifying planar patch of mesh (planar_patch_faces; its faces' nodes and
/// the nodes of their edges) onto the patch's plane. Nodes on feature curves keep their place
/// along the curve (an arc bounding a flat face lies in its plane).
PlanarPatchResult flatten_planar_patches(const Mesh& mesh, const Topology& T, HighOrderMesh& hm,
                                         const PlanarPatchOptions& opt = {},
                                         const std::vector<char>* edge_feature = nullptr);

/// The same with the patches already found (anchor = planar_patch_faces(...)).
PlanarPatchResult flatten_planar_patches(const Mesh& mesh, const Topology& T, HighOrderMesh& hm,
                                         const std::vector<int>& anchor);

}  // namespace hocurve
