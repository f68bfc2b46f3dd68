// Fitting stencils that never cross feature edges: the wedges of each vertex (sectors of
// incident faces between consecutive feature edges) and ring growth from a wedge.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <vector>

namespace hocurve {

/// Wedges of every vertex. A vertex off the features has one wedge holding all its faces; a
/// vertex on a feature has one wedge per sector between feature (or boundary / non-manifold)
/// edges. A face corner belongs to exactly one wedge.
/// - wedge_vertex[w]: the vertex of wedge w.
/// - wedge_start / wedge_faces: CSR list of the faces of wedge w (ascending).
/// - corner_wedge: #F x 3, wedge of face f's corner j.
/// - vertex_wedge_start: CSR, the wedges of vertex v are vertex_wedge_start[v] .. [v+1]-1
///   (wedges are numbered by vertex, then by smallest face).
struct Wedges {
  std::vector<int> wedge_vertex;
  std::vector<int> wedge_start, wedge_faces;
  Eigen::MatrixXi corner_wedge;
  std::vector<int> vertex_wedge_start;
  std::vector<char> cone;  ///< per vertex: a cone point (Features::vertex_cone); empty: none
  bool is_cone(int v) const { return !cone.empty() && cone[v]; }
  int num_wedges() const { return static_cast<int>(wedge_vertex.size()); }
  int vertex_wedges(int v) const { return vertex_wedge_start[v + 1] - vertex_wedge_start[v]; }
  /// Wedge w's vertex has other wedges too: it lies on a feature and w sees one side of it.
  bool one_sided(int w) const { return vertex_wedges(wedge_vertex[w]) > 1; }
};

/// Splits the faces around every vertex into wedges separated by feature edges.
/// edge_feature: per Topology edge, 1 if it is a feature (may be empty: no features).
/// cone_vertex: per vertex, 1 for a cone point (may be empty): stencils do not grow across it.
Wedges build_wedges(const Mesh& mesh, const Topology& T, const std::vector<char>& edge_feature,
                    const std::vector<char>& cone_vertex = {});

struct StencilOptions {
  int min_rings = 2;        ///< rings always taken
  int max_rings = 6;        ///< growth stops here even when short of points
  int target_points = 20;   ///< grow rings until the stencil has at least this many vertices
  int max_points = 128;     ///< growth stops once this many vertices are reached
};

/// One fitting stencil: the vertices reached (the centre first) and the faces of the region.
struct Stencil {
  std::vector<int> vertices;  ///< centre vertex first, then by ring, ascending index within a ring
  std::vector<int> faces;     ///< faces of the grown region (ascending)
  int rings = 0;
};

/// Grows rings from wedge w: each ring adds, around every vertex of the region, the faces of
/// that vertex's wedges already touched by the region, so the region never crosses a feature;
/// nor a cone point (its faces join the region only from the cone's own wedge).
Stencil grow_stencil(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                     const StencilOptions& opt);

/// A set of non-negative integers that empties in O(1): open addressing over (key, stamp)
/// slots, so repeated per-vertex work (one instance per thread) neither allocates nor leaves
/// L1 (a stencil's few hundred faces; a dense #F array of marks missed the cache on every test).
class StampSet {
 public:
  /// Empties the set.
  void clear() {
    size_ = 0;
    if (++stamp_ == 0) {
      for (Slot& s : slots_) s.stamp = 0;
      stamp_ = 1;
    }
  }
  /// True when i was not yet a member.
  bool insert(int i) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    Slot& s = slots_[find(i)];
    if (s.stamp == stamp_) return false;
    s = {i, stamp_};
    ++size_;
    return true;
  }
  bool contains(int i) const {
    if (slots_.empty()) return false;
    const Slot& s = slots_[find(i)];
    return s.stamp == stamp_;
  }

 private:
  struct Slot { int key = 0; unsigned stamp = 0; };
  std::vector<Slot> slots_;
  size_t size_ = 0;
  unsigned stamp_ = 1;
  int shift_ = 32;
  /// The slot holding i, or the empty slot where it would go (linear probing).
  size_t find(int i) const {
    const size_t mask = slots_.size() - 1;
    size_t h = (static_cast<unsigned>(i) * 0x9E3779B1u) >> shift_;
    while (slots_[h].stamp == stamp_ && slots_[h].key != i) h = (h + 1) & mask;
    return h;
  }
  void grow() {
    std::vector<Slot> old;
    old.swap(slots_);
    const size_t n = old.empty() ? 256 : 2 * old.size();
    slots_.assign(n, Slot{});
    shift_ = 32;
    for (size_t m = n; m > 1; m >>= 1) --shift_;
    for (const Slot& s : old)
      if (s.stamp == stamp_) slots_[find(s.key)] = s;
  }
};

/// Reusable working memory of grow_stencil (one per thread). Results never depend on it.
struct StencilScratch {
  StampSet faces, vertices;
  std::vector<int> frontier, new_faces;
};

/// The vertices (ascending) of `rings` face rings around interior edge e: its faces, then at
/// each step the faces across the region's manifold edges not marked in `wall`.
/// `faces` and `seen` are working memory (`seen` holds faces, then vertices).
void edge_region_vertices(const Mesh& mesh, const Topology& T, const std::vector<char>& wall, int e, int rings,
                          std::vector<int>& faces, StampSet& seen, std::vector<int>& out);

/// Local frame of the fits around interior edge e (curvature_jump, the kink test): origin o at
/// its midpoint, n the given normal normalised, t the edge's direction with its n part removed,
/// s = n x t, h its length. valid is false for a zero-length edge or a zero normal.
struct EdgeFrame {
  Eigen::Vector3d o, t, s, n;
  double h = 0;
  bool valid = false;
};
EdgeFrame edge_frame(const Mesh& mesh, const Topology& T, int e, Eigen::Vector3d normal);
/// The same with normal the sum of its two faces' unit normals.
EdgeFrame edge_frame(const Mesh& mesh, const Topology& T, int e);

/// grow_stencil with caller-provided working memory (the same stencil, no hashing).
Stencil grow_stencil(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                     const StencilOptions& opt, StencilScratch& scratch);

}  // namespace hocurve
