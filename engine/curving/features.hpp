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
};

/// Detects feature edges, chains them into curves and marks corners.
Features detect_features(const Mesh& mesh, const Topology& T, const FeatureOptions& opt = {});

}  // namespace hocurve
