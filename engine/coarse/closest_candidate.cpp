#include "engine/coarse/closest_candidate.hpp"

#include "engine/core/union_find.hpp"
#include "engine/highorder/bezier.hpp"
#include "engine/highorder/lagrange.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <limits>
#include <numeric>

namespace hocurve {

namespace {

bool rows_differ(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, Eigen::Index start, int n) {
  return n > 0 && a.middleRows(start, n) != b.middleRows(start, n);
}

/// max over i < n of value(i), in parallel; once a part reaches `bound` it skips the rest of its
/// range (the result is then >= bound, whatever the schedule: the caller only compares it).
template <class F>
double parallel_max(size_t n, double bound, F&& value) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n), 0.0,
      [&](const tbb::blocked_range<size_t>& r, double m) {
        for (size_t i = r.begin(); i < r.end() && m < bound; ++i) m = std::max(m, value(i));
        return m;
      },
      [](double a, double b) { return std::max(a, b); });
}

/// The largest distance, both ways, between the elements `faces` of hm and the dense mesh: the
/// elements' samples to the dense mesh, and the samples of `dense_faces` (those with a vertex that
/// the map puts in the elements) to the elements and the ones around them (`ring`: faces too).
/// Returns as soon as it reaches `bound` (the best so far: that candidate cannot win any more).
double cluster_distance(const HighOrderMesh& hm, const std::vector<int>& faces, const std::vector<int>& ring,
                        const std::vector<int>& dense_faces, const Mesh& fine, const TriangleGrid& fine_grid,
                        const Eigen::MatrixXd& uv, const Eigen::MatrixXd& dense_uv, double bound) {
  double worst = parallel_max(faces.size(), bound, [&](size_t i) {
    const Eigen::MatrixXd S = evaluate_triangle(element_nodes(hm, faces[i]), hm.order, uv);
    double m = 0;
    for (Eigen::Index k = 0; k < S.rows(); ++k) m = std::max(m, grid_distance(fine_grid, S.row(k).transpose()));
    return m;
  });
  if (worst >= bound) return worst;  // cannot win: ties go to the earlier candidate
  // With the elements around the cluster (the same in every candidate): dense points by its border
  // find their closest point there too.
  const Mesh tess = tessellate(hm, 6, &ring);
  const TriangleGrid g = build_triangle_grid(tess);
  // Dense points outside the elements' box have their closest point beyond them (the same in every
  // candidate), and a grid search from outside its box visits every cell.
  const Eigen::Array3d lo = tess.V.colwise().minCoeff().transpose(), hi = tess.V.colwise().maxCoeff().transpose();
  return std::max(worst, parallel_max(dense_faces.size(), bound, [&](size_t i) {
    const int f = dense_faces[i];
    double m = 0;
    for (Eigen::Index k = 0; k < dense_uv.rows(); ++k) {
      const double u = dense_uv(k, 0), v = dense_uv(k, 1);
      const Eigen::Vector3d x = (1 - u - v) * fine.V.row(fine.F(f, 0)) + u * fine.V.row(fine.F(f, 1)) +
                                v * fine.V.row(fine.F(f, 2));
      if ((x.array() >= lo).all() && (x.array() <= hi).all()) m = std::max(m, grid_distance(g, x));
    }
    return m;
  }));
}

}  // namespace

ClosestCandidateResult choose_closest_candidate(const std::vector<HighOrderMesh>& candidates, const Mesh& fine,
                                                const TriangleGrid& fine_grid, const CoarseMap& map,
                                                HighOrderMesh& out, int samples) {
  ClosestCandidateResult R;
  R.chosen.assign(candidates.size(), 0);
  if (candidates.empty()) return R;
  out = candidates[0];
  const int nc = static_cast<int>(candidates.size());
  if (nc == 1) return R;
  const int nf = out.num_faces(), ne = static_cast<int>(out.E.rows());
  const int npe = out.nodes_per_edge(), npf = out.nodes_per_face();

  // Where the candidates differ, and the clusters those places form.
  std::vector<char> edge_diff(ne, 0), elem_diff(nf, 0);
  for (int c = 1; c < nc; ++c) {
    for (int e = 0; e < ne; ++e)
      edge_diff[e] |= rows_differ(candidates[c].edge_nodes, out.edge_nodes, static_cast<Eigen::Index>(e) * npe, npe);
    for (int f = 0; f < nf; ++f)
      elem_diff[f] |= rows_differ(candidates[c].face_nodes, out.face_nodes, static_cast<Eigen::Index>(f) * npf, npf);
  }
  std::vector<int> parent(nf), edge_face(ne, -1);
  std::iota(parent.begin(), parent.end(), 0);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      const int e = out.FE(f, j);
      if (!edge_diff[e]) continue;
      elem_diff[f] = 1;
      if (edge_face[e] < 0) edge_face[e] = f;
      else parent[find_root(parent, f)] = find_root(parent, edge_face[e]);
    }
  std::vector<int> cluster_of(nf, -1);
  std::vector<std::vector<int>> clusters;
  for (int f = 0; f < nf; ++f) {
    if (!elem_diff[f]) continue;
    const int r = find_root(parent, f);
    if (cluster_of[r] < 0) cluster_of[r] = static_cast<int>(clusters.size()), clusters.emplace_back();
    clusters[cluster_of[r]].push_back(f);
  }
  R.clusters = static_cast<int>(clusters.size());
  std::vector<std::vector<int>> dense_faces(clusters.size());
  for (int f = 0; f < fine.num_faces(); ++f) {  // increasing f: each list sorted, no repeats
    int last = -1;
    for (int j = 0; j < 3; ++j) {
      const int cf = map.vertex_coarse_face[fine.F(f, j)];
      if (cf < 0 || !elem_diff[cf]) continue;
      const int k = cluster_of[find_root(parent, cf)];
      if (k != last) dense_faces[k].push_back(f), last = k;
    }
  }
  // Each cluster with every element that shares a corner with it.
  std::vector<std::vector<int>> vertex_faces(out.V.rows());
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) vertex_faces[out.F(f, j)].push_back(f);
  std::vector<std::vector<int>> rings(clusters.size());
  for (size_t k = 0; k < clusters.size(); ++k) {
    for (int f : clusters[k])
      for (int j = 0; j < 3; ++j)
        for (int g : vertex_faces[out.F(f, j)]) rings[k].push_back(g);
    std::sort(rings[k].begin(), rings[k].end());
    rings[k].erase(std::unique(rings[k].begin(), rings[k].end()), rings[k].end());
  }

  // Each cluster's closest candidate.
  const Eigen::MatrixXd uv = bernstein_lattice(std::max(samples, out.order)), dense_uv = bernstein_lattice(3);
  std::vector<int> best(clusters.size(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, clusters.size()), [&](const tbb::blocked_range<size_t>& rg) {
    for (size_t k = rg.begin(); k < rg.end(); ++k) {
      double bd = std::numeric_limits<double>::infinity();
      for (int c = 0; c < nc; ++c) {
        // A candidate equal to an earlier one on this cluster cannot win the tie.
        bool seen = false;
        for (int c0 = 0; c0 < c && !seen; ++c0) {
          seen = true;
          for (int f : clusters[k])
            if (element_nodes(candidates[c], f) != element_nodes(candidates[c0], f)) { seen = false; break; }
        }
        if (seen) continue;
        const double d = cluster_distance(candidates[c], clusters[k], rings[k], dense_faces[k], fine, fine_grid, uv, dense_uv, bd);
        if (d < bd) bd = d, best[k] = c;
      }
    }
  });
  for (size_t k = 0; k < clusters.size(); ++k) {
    const int c = best[k];
    ++R.chosen[c];
    if (c == 0) continue;
    for (int f : clusters[k]) {
      ++R.elements_changed;
      out.face_nodes.middleRows(static_cast<Eigen::Index>(f) * npf, npf) =
          candidates[c].face_nodes.middleRows(static_cast<Eigen::Index>(f) * npf, npf);
      for (int j = 0; j < 3; ++j) {
        const Eigen::Index r = static_cast<Eigen::Index>(out.FE(f, j)) * npe;
        out.edge_nodes.middleRows(r, npe) = candidates[c].edge_nodes.middleRows(r, npe);
      }
    }
  }
  return R;
}

}  // namespace hocurve
