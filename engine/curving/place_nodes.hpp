// High-order node placement: the WALF blend of the corner fits at each reference node.
// Edge nodes depend only on the edge's two end fits and are computed once per edge, so the
// mesh is conforming by construction; edges on feature curves follow the curve fits.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/curve_fit.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/long_edges.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <vector>

namespace hocurve {

/// Surface point for barycentric coordinates xi of face f: x = sum xi_j X_j pushed onto each
/// corner's wedge fit, blended with weights xi (WALF; docs/algorithm.md, section 6).
/// face_fit (may be null): an exact fit that holds face f (face_exact_fits), used instead.
Eigen::Vector3d blend_point(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits,
                            int f, const Eigen::Vector3d& xi, const LocalFit* face_fit = nullptr);

/// The blend of x's projections onto the corner fits of face f, with weights xi (x projected onto
/// face_fit instead where that is given).
Eigen::Vector3d blend_projection(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits, int f,
                                 const Eigen::Vector3d& xi, const Eigen::Vector3d& x,
                                 const LocalFit* face_fit = nullptr);

/// Barycentric coordinates, in face f (one of edge e's faces), of the point at parameter t from
/// E(e,0) to E(e,1). Placing an edge's nodes through one face per edge keeps them conforming.
Eigen::Vector3d edge_barycentric(const Mesh& mesh, const Topology& T, int e, int f, double t);

struct PlacementResult {
  HighOrderMesh mesh;
  long long curve_edges = 0;   ///< edges placed along feature-curve fits
  long long long_edges = 0;    ///< unreached long edges placed on a PN curve (off feature curves)
  long long face_exact_fits = 0;  ///< faces whose nodes are on a neighbour's exact surface (face_fits)
  std::vector<char> face_on_exact;  ///< per face: 1 where such a surface placed its nodes
  /// Per edge, 1 where it is off the feature curves but its faces' exact surfaces cross along it,
  /// and its nodes are on that crossing (exact_crossing_point in place_nodes.cpp).
  std::vector<char> crossing;
  long long crossing_edges = 0;
  double seconds = 0;
};

/// Places the order-p nodes (distribution d) of every edge and face (TBB-parallel; every item
/// is computed independently, so the result does not depend on the thread count).
/// curves / feat may be null: then every edge uses the surface blend. long_edge (may be null):
/// its faces (LongEdgeResult::face) and unreached edges go on their PN triangles (long_face_point).
/// planar (may be null): per face, planar_patch_faces (>= 0: in a flat patch); a feature edge
/// between two flat patches is straight. face_fits (may be null): per face, face_exact_fits; a
/// face with one has its nodes on it, and an edge takes its first face's (else its second's).
PlacementResult place_nodes(const Mesh& mesh, const Topology& T, const Wedges& W,
                            const std::vector<LocalFit>& fits, const Features* feat,
                            const CurveFitResult* curves, int p, NodeDistribution d,
                            const LongEdgeResult* long_edge = nullptr, const std::vector<int>* planar = nullptr,
                            const std::vector<const LocalFit*>* face_fits = nullptr);

}  // namespace hocurve
