#include "engine/core/topology.hpp"

#include <algorithm>
#include <cstdint>

namespace hocurve {

Topology build_topology(const Eigen::MatrixXi& F, int nv) {
  Topology T;
  const int nf = static_cast<int>(F.rows());
  // (min,max,face,corner) records in that order: deterministic edge numbering by vertex pair.
  // A counting sort by min vertex keeps the (face, corner) order of creation; a stable insertion
  // sort of each vertex's few records by max vertex finishes it (linear time: a comparison sort
  // of all 3F records was a third of reading and validating a 200k-triangle mesh).
  struct Rec { int a, b, f, j; };
  int buckets = nv;
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) buckets = std::max(buckets, F(f, j) + 1);
  std::vector<int> first(static_cast<size_t>(buckets) + 1, 0);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) ++first[std::min(F(f, j), F(f, (j + 1) % 3)) + 1];
  for (int v = 0; v < buckets; ++v) first[v + 1] += first[v];
  std::vector<Rec> recs(3 * static_cast<size_t>(nf));
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int j = 0; j < 3; ++j) {
        const int a = F(f, j), b = F(f, (j + 1) % 3);
        recs[fill[std::min(a, b)]++] = {std::min(a, b), std::max(a, b), f, j};
      }
  }
  for (int v = 0; v < buckets; ++v)
    for (int i = first[v] + 1; i < first[v + 1]; ++i)
      for (int k = i; k > first[v] && recs[k - 1].b > recs[k].b; --k) std::swap(recs[k - 1], recs[k]);
  T.FE.resize(nf, 3);
  std::vector<std::pair<int, int>> edges;
  for (size_t i = 0; i < recs.size();) {
    size_t k = i;
    const int e = static_cast<int>(edges.size());
    edges.push_back({recs[i].a, recs[i].b});
    T.edge_faces.emplace_back();
    while (k < recs.size() && recs[k].a == recs[i].a && recs[k].b == recs[i].b) {
      T.FE(recs[k].f, recs[k].j) = e;
      auto& ef = T.edge_faces.back();
      if (ef.empty() || ef.back() != recs[k].f) ef.push_back(recs[k].f);
      ++k;
    }
    i = k;
  }
  T.E.resize(static_cast<Eigen::Index>(edges.size()), 2);
  for (size_t e = 0; e < edges.size(); ++e) T.E(e, 0) = edges[e].first, T.E(e, 1) = edges[e].second;

  auto csr = [nv](std::vector<int>& start, std::vector<int>& items, auto&& for_each_pair) {
    start.assign(nv + 1, 0);
    for_each_pair([&](int v, int) { ++start[v + 1]; });
    for (int v = 0; v < nv; ++v) start[v + 1] += start[v];
    items.resize(start[nv]);
    std::vector<int> fill(start.begin(), start.end() - 1);
    for_each_pair([&](int v, int x) { items[fill[v]++] = x; });
  };
  csr(T.vf_start, T.vf_faces, [&](auto&& emit) {
    for (int f = 0; f < nf; ++f)
      for (int j = 0; j < 3; ++j) emit(F(f, j), f);
  });
  csr(T.ve_start, T.ve_edges, [&](auto&& emit) {
    for (int e = 0; e < T.num_edges(); ++e) emit(T.E(e, 0), e), emit(T.E(e, 1), e);
  });
  return T;
}

}  // namespace hocurve
