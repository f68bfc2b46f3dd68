#include "engine/curving/tangent_junctions.hpp"

#include "engine/core/union_find.hpp"
#include "engine/curving/exact_quadric.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

CurvatureJump curvature_jump(const Mesh& mesh, const Topology& T, const std::vector<char>& wall, int e,
                             JumpScratch& scratch) {
  CurvatureJump J;
  if (T.edge_faces[e].size() != 2) return J;
  const EdgeFrame fr = edge_frame(mesh, T, e);
  if (!fr.valid) return J;
  const Eigen::Vector3d &t = fr.t, &s = fr.s, &n = fr.n, &o = fr.o;
  const double h = fr.h;
  std::vector<int>& ring = scratch.vertices;
  edge_region_vertices(mesh, T, wall, e, 3, scratch.faces, scratch.seen, ring);
  const int k = static_cast<int>(ring.size());
  constexpr int m = 8;
  if (k < m + 6) return J;
  // Normal equations, fixed size: their Cholesky factor is the R of the weighted system's QR, so
  // L(j, j) is column j's part outside the span of the columns before it, and the forward solve
  // gives Q^T z (the drop of the residual by each column in turn).
  Eigen::Matrix<double, m, m> G = Eigen::Matrix<double, m, m>::Zero();
  Eigen::Matrix<double, m, 1> Az = Eigen::Matrix<double, m, 1>::Zero();
  double zz = 0;
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector3d d = (Eigen::Vector3d(mesh.V.row(ring[i])) - o) / h;
    const double x = d.dot(t), y = d.dot(s), w = std::exp(-(x * x + y * y) / 2.0);
    const double yp = std::max(y, 0.0), z = d.dot(n);
    Eigen::Matrix<double, m, 1> row;
    row << 1, x, y, x * x, x * y, y * y, yp * yp, x * yp * yp;
    G.selfadjointView<Eigen::Lower>().rankUpdate(row, w * w);
    Az += (w * w * z) * row;
    zz += w * w * z * z;
  }
  const Eigen::LLT<Eigen::Matrix<double, m, m>> llt(G.selfadjointView<Eigen::Lower>());
  if (llt.info() != Eigen::Success) return J;
  const Eigen::Matrix<double, m, m> L = llt.matrixL();
  // Determined: no column (the jump columns last) nearly a combination of the ones before it.
  for (int j = 0; j < m; ++j)
    if (!(L(j, j) > 1e-3 * std::sqrt(G(j, j)))) return J;
  const Eigen::Matrix<double, m, 1> qz = L.triangularView<Eigen::Lower>().solve(Az);
  const Eigen::Matrix<double, m, 1> c = L.transpose().triangularView<Eigen::Upper>().solve(qz);
  if (!c.allFinite()) return J;
  const double r1 = std::max(zz - qz.squaredNorm(), 0.0);
  const double r0 = r1 + qz[m - 2] * qz[m - 2] + qz[m - 1] * qz[m - 1];
  J.determined = true;
  J.jump = std::abs(2 * c[m - 2]);
  J.residual_ratio = r0 > 0 ? std::sqrt(r1 / r0) : 1.0;
  return J;
}

// A curved face too narrow for a fit of its own (every vertex within min_width edge hops of its
// border: a fillet two edges long between corner spheres) fits better across its borders than
// between them: the junctions between it and other curved faces are dropped (those with a flat
// face stay: a plane is fitted exactly by any degree). True when any was dropped.
static bool drop_narrow_curved_regions(const Mesh& mesh, const Topology& T, const std::vector<char>& wall,
                                       const std::vector<double>& theta, double flat_deg, int min_width,
                                       std::vector<char>& out) {
  if (std::find(out.begin(), out.end(), 1) == out.end()) return false;
  const int ne = T.num_edges(), nv = mesh.num_vertices(), nf = mesh.num_faces();
  auto inner = [&](int e) { return !out[e] && !wall[e] && T.edge_faces[e].size() == 2; };
  // Faces: regions across inner edges (union-find).
  std::vector<int> parent(nf);
  for (int f = 0; f < nf; ++f) parent[f] = f;
  auto find = [&](int f) { return find_root(parent, f); };
  for (int e = 0; e < ne; ++e)
    if (inner(e)) parent[find(T.edge_faces[e][0])] = find(T.edge_faces[e][1]);
  // Vertices: edge hops from the nearest border vertex (breadth first over inner edges).
  std::vector<int> hops(nv, -1), queue;
  for (int e = 0; e < ne; ++e)
    if (!inner(e))
      for (int j = 0; j < 2; ++j)
        if (hops[T.E(e, j)] < 0) hops[T.E(e, j)] = 0, queue.push_back(T.E(e, j));
  for (std::size_t i = 0; i < queue.size(); ++i) {
    const int v = queue[i];
    auto [b, end] = T.edges_of(v);
    for (const int* it = b; it != end; ++it) {
      const int w = T.other(*it, v);
      if (inner(*it) && hops[w] < 0) hops[w] = hops[v] + 1, queue.push_back(w);
    }
  }
  std::vector<int> width(nf, 0);   // per region root: largest hop count of its vertices
  std::vector<char> curved(nf, 0);  // per region root: an inner edge bends by flat_deg or more
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) width[find(f)] = std::max(width[find(f)], hops[mesh.F(f, j)]);
  for (int e = 0; e < ne; ++e)
    if (inner(e) && theta[e] >= flat_deg) curved[find(T.edge_faces[e][0])] = 1;
  bool dropped = false;
  for (int e = 0; e < ne; ++e) {
    if (!out[e] || T.edge_faces[e].size() != 2) continue;
    const int ra = find(T.edge_faces[e][0]), rb = find(T.edge_faces[e][1]);
    if (curved[ra] && curved[rb] && std::min(width[ra], width[rb]) <= min_width) out[e] = 0, dropped = true;
  }
  return dropped;
}

// The steps are those of FeatureOptions::tangent_junctions: passing edges, connected sets of at
// least junction_min_edges (a junction is a curve; isolated passes are noise), free ends
// continued, curves still ending in the open dropped.
std::vector<char> tangent_junction_edges(const Mesh& mesh, const Topology& T, const std::vector<char>& wall,
                                         const std::vector<double>& theta, const FeatureOptions& opt) {
  const int ne = T.num_edges(), nv = mesh.num_vertices();
  // A jump of junction_min_jump / h bends the curved side by about half that many radians per
  // edge: edges with no dihedral angle of a quarter of it at their ends are not fitted (on a
  // finely meshed smooth surface, none is).
  std::vector<double> bend(nv, 0.0);
  for (int e = 0; e < ne; ++e)
    for (int j = 0; j < 2; ++j) bend[T.E(e, j)] = std::max(bend[T.E(e, j)], theta[e]);
  const double min_bend = 0.25 * opt.junction_min_jump * 180 / std::numbers::pi;
  // pass: 2 passes; 1 passes junction_weak_ratio only (such edges may extend a curve's free end:
  // the end edges' stencils reach the next junction and fit less well).
  std::vector<char> pass(ne, 0);
  tbb::enumerable_thread_specific<JumpScratch> scratch;
  tbb::parallel_for(tbb::blocked_range<int>(0, ne, 256), [&](const tbb::blocked_range<int>& r) {
    JumpScratch& js = scratch.local();
    for (int e = r.begin(); e < r.end(); ++e) {
      if (wall[e] || T.edge_faces[e].size() != 2 || theta[e] > opt.angle_deg ||
          std::max(bend[T.E(e, 0)], bend[T.E(e, 1)]) < min_bend)
        continue;
      const CurvatureJump J = curvature_jump(mesh, T, wall, e, js);
      if (J.determined && J.jump >= opt.junction_min_jump && J.jump <= opt.junction_max_jump)
        pass[e] = J.residual_ratio <= opt.junction_max_ratio ? 2 : J.residual_ratio <= opt.junction_weak_ratio ? 1 : 0;
    }
  });
  // Connected sets of passing edges (through shared vertices): union-find on vertices.
  std::vector<int> parent(nv);
  for (int v = 0; v < nv; ++v) parent[v] = v;
  auto find = [&](int v) { return find_root(parent, v); };
  for (int e = 0; e < ne; ++e)
    if (pass[e] == 2) parent[find(T.E(e, 0))] = find(T.E(e, 1));
  std::vector<int> size(nv, 0);
  for (int e = 0; e < ne; ++e)
    if (pass[e] == 2) ++size[find(T.E(e, 0))];
  std::vector<char> out(ne, 0);
  for (int e = 0; e < ne; ++e) out[e] = pass[e] == 2 && size[find(T.E(e, 0))] >= opt.junction_min_edges;
  std::vector<int> valence(nv, 0);  // junction and wall edges at each vertex
  auto count_valence = [&] {
    std::fill(valence.begin(), valence.end(), 0);
    for (int e = 0; e < ne; ++e)
      if (out[e] || wall[e]) ++valence[T.E(e, 0)], ++valence[T.E(e, 1)];
  };
  count_valence();
  // A junction's end edges, whose stencils reach the next junction, fit less well: from each
  // free end, follow the weaker edges that continue the curve straight on (within
  // corner_angle_deg) until they meet another feature.
  const double cos_max = std::cos(opt.corner_angle_deg * std::numbers::pi / 180);
  for (int e0 = 0; e0 < ne; ++e0) {
    if (!out[e0]) continue;
    for (int side = 0; side < 2; ++side) {
      int prev = T.E(e0, 1 - side), v = T.E(e0, side);
      for (int step = 0; step < 8 && valence[v] == 1; ++step) {
        const Eigen::Vector3d d = (mesh.V.row(v) - mesh.V.row(prev)).normalized();
        int best = -1;
        double best_cos = cos_max;
        auto [b, end] = T.edges_of(v);
        for (const int* it = b; it != end; ++it) {
          if (pass[*it] == 0 || out[*it]) continue;
          const double c = d.dot((mesh.V.row(T.other(*it, v)) - mesh.V.row(v)).normalized());
          if (c > best_cos) best_cos = c, best = *it;
        }
        if (best < 0) break;
        out[best] = 1;
        const int w = T.other(best, v);
        ++valence[v], ++valence[w];
        prev = v, v = w;
      }
    }
  }
  // A junction borders a face: it ends on other junctions or features. Peel the curves that
  // still end in the open (a partial find, where the stencils reach across narrow faces, does
  // more harm than none: fits then reach around the free ends).
  auto peel = [&] {
    std::vector<int> open;
    for (int v = 0; v < nv; ++v)
      if (valence[v] == 1) open.push_back(v);
    while (!open.empty()) {
      const int v = open.back();
      open.pop_back();
      auto [b, end] = T.edges_of(v);
      for (const int* it = b; it != end; ++it)
        if (out[*it]) {
          out[*it] = 0;
          const int w = T.other(*it, v);
          --valence[v];
          if (--valence[w] == 1) open.push_back(w);
        }
    }
  };
  peel();
  if (drop_narrow_curved_regions(mesh, T, wall, theta, min_bend, opt.junction_min_width, out)) {
    count_valence();
    peel();
  }
  // No junction inside one exact quadric: an elliptic cylinder's curvature runs from b / a^2 to
  // a / b^2 round it, and at a few edges per radius that reads as jumps (31 edges at h = 0.1, P4
  // 8.1e-4; without them 9.8e-6). Only on the junctions left (on every passing edge: a scan's
  // features 50% slower).
  if (opt.exact_quadrics) {
    std::vector<char> inside(ne, 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, ne, 64), [&](const tbb::blocked_range<int>& r) {
      for (int e = r.begin(); e < r.end(); ++e)
        inside[e] = out[e] && edge_on_exact_quadric(mesh, T, e, theta, opt.quadric, opt.angle_deg);
    });
    if (std::find(inside.begin(), inside.end(), 1) != inside.end()) {
      for (int e = 0; e < ne; ++e) out[e] = out[e] && !inside[e];
      count_valence();
      peel();
    }
  }
  return out;
}

}  // namespace hocurve
