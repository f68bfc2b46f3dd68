// Feature curves of a triangle mesh: sharp edges, open boundaries, non-manifold edges and
// borders between input entities, chained into curves with corners.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <vector>

namespace hocurve {

struct FeatureOptions {
  double angle_deg = 35.0;         ///< an edge is sharp when its dihedral angle (between face normals) exceeds this
  double corner_angle_deg = 35.0;  ///< a vertex on a single curve is a corner when the curve turns more than this
  bool entity_borders = true;      ///< edges between faces of different input entities are features
  /// Open curves made only of sharp edges, with a free end (feature valence 1) and fewer than
  /// this many edges, are dropped as noise (scanned meshes have many); 0 keeps every curve.
  int min_dangling_edges = 0;
};

struct Features {
  std::vector<char> edge_feature;     ///< per Topology edge: 1 if a feature edge
  std::vector<char> vertex_feature;   ///< per vertex: 1 if on a feature edge
  std::vector<char> vertex_corner;    ///< per vertex: 1 if a corner (curves meet, end or turn sharply): stays put
  /// Feature curves as vertex chains between corners (or closed loops: front()==back()).
  std::vector<std::vector<int>> curves;
  std::vector<int> edge_curve;        ///< per edge: curve index, -1 if not a feature
  long long sharp_edges = 0, boundary_edges = 0, nonmanifold_edges = 0, entity_border_edges = 0;
  int corners = 0;
  long long feature_edges = 0;        ///< edges with edge_feature == 1 (an edge may be of several kinds above)
  int closed_curves = 0;              ///< curves that are closed loops without corners
  long long pruned_edges = 0;         ///< sharp edges dropped by min_dangling_edges (still counted in sharp_edges)
};

/// Detects feature edges, chains them into curves and marks corners.
/// An interior edge (two faces) is sharp when the angle between its two face normals, as
/// oriented in the input, exceeds opt.angle_deg (35° by default: a 90° CAD rim is caught, a
/// sphere discretised with >= 10 segments around is not). Boundary and non-manifold edges are
/// always features; entity borders when opt.entity_borders. Faces of zero area have no normal
/// and never make an edge sharp. Curves and corners are numbered deterministically (by vertex
/// and edge index).
Features detect_features(const Mesh& mesh, const Topology& T, const FeatureOptions& opt = {});

}  // namespace hocurve
