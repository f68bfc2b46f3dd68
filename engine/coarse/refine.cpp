#include "engine/coarse/refine.hpp"

#include "engine/coarse/surface_distance.hpp"
#include "engine/core/stopwatch.hpp"
#include "engine/core/topology.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <numeric>
#include <optional>
#include <set>

namespace hocurve {

namespace {

using EdgeSet = std::set<std::pair<int, int>>;  ///< edges by their vertices, smaller first

EdgeSet edge_set(const Topology& T, const std::vector<char>& marked) {
  EdgeSet out;
  for (int e = 0; e < T.num_edges(); ++e)
    if (marked[e]) out.insert(std::minmax(T.E(e, 0), T.E(e, 1)));
  return out;
}

/// Per element in `worst` (worst first, at most budget of them), the edge to split: the terminal
/// edge of its longest-edge propagation path (Rivara's LEPP: from the element across its longest
/// edge until two neighbours share their longest edge), so that bisection does not make thinner
/// triangles; the edge before it on the path when the terminal edge may not split (taken by an
/// element before, or non-manifold).
std::vector<std::array<int, 2>> edges_to_split(const DecimateResult& dec, const std::vector<int>& worst, int budget) {
  const Mesh& C = dec.coarse;
  const Topology T = build_topology(C.F, C.num_vertices());
  auto length = [&](int e) { return (C.V.row(T.E(e, 0)) - C.V.row(T.E(e, 1))).squaredNorm(); };
  auto longest = [&](int f) {
    int best = T.FE(f, 0);
    for (int j = 1; j < 3; ++j)
      if (length(T.FE(f, j)) > length(best)) best = T.FE(f, j);
    return best;
  };
  std::vector<char> taken(T.num_edges(), 0);
  auto may_split = [&](int e) {
    const auto& ef = T.edge_faces[e];
    return !taken[e] && ef.size() <= 2;  // interior or open-boundary edges; not non-manifold ones
  };
  std::vector<std::array<int, 2>> out;
  for (int f : worst) {
    if (static_cast<int>(out.size()) >= budget) break;
    int e = longest(f), before = -1;
    for (int step = 0; step < 64 && T.edge_faces[e].size() == 2; ++step) {
      const int g = T.edge_faces[e][0] == f ? T.edge_faces[e][1] : T.edge_faces[e][0];
      const int eg = longest(g);
      if (eg == e) break;  // terminal edge
      before = e, f = g, e = eg;
    }
    if (!may_split(e)) e = before;
    if (e < 0 || !may_split(e)) continue;
    taken[e] = 1;
    out.push_back({T.E(e, 0), T.E(e, 1)});
  }
  return out;
}

}  // namespace

RefineResult lift_and_refine(const Mesh& fine, DecimateResult& dec, const LiftOptions& lopt, const RefineOptions& opt,
                             const DenseSurface* dense, LiftResult* lifted) {
  RefineResult R;
  std::optional<DenseSurface> own;
  const DenseSurface& S = dense ? *dense : own.emplace(build_dense_surface(fine, dense_surface_options(lopt)));
  auto t = Clock::now();
  R.lift = lifted ? std::move(*lifted) : lift_coarse(fine, dec, lopt, &S);
  R.lift.seconds_dense = S.seconds;
  R.seconds_lift += seconds_since(t);
  R.faces_before = dec.coarse.num_faces();
  const double diag = R.lift.bbox_diagonal, tol = opt.tolerance * diag;
  if (opt.tolerance <= 0) {
    R.message = "no refinement (tolerance 0)";
    return R;
  }
  const int max_faces = opt.max_faces > 0 ? opt.max_faces : fine.num_faces();
  // The rounds lift again without reporting the lifting's stages (progress would run backwards).
  LiftOptions quiet = lopt;
  quiet.progress = nullptr;
  // The round with the smallest largest deviation: copied before its splits, restored at the end.
  std::unique_ptr<std::pair<DecimateResult, LiftResult>> best;
  double best_deviation = 0;
  int best_rounds = 0;
  for (;;) {
    t = Clock::now();
    const std::vector<double> dev = element_deviation(R.lift.mesh, fine);
    R.seconds_measure += seconds_since(t);
    std::vector<int> worst;
    for (int f = 0; f < static_cast<int>(dev.size()); ++f)
      if (dev[f] > tol) worst.push_back(f);
    std::stable_sort(worst.begin(), worst.end(), [&](int a, int b) { return dev[a] > dev[b]; });
    R.deviation_after = (dev.empty() ? 0.0 : *std::max_element(dev.begin(), dev.end())) / diag;
    if (R.rounds == 0) R.deviation_before = R.deviation_after;
    // The largest deviation can rise (new fits and repairs around the splits): keep the best.
    if (R.rounds == 0 || R.deviation_after < best_deviation) {
      best_deviation = R.deviation_after;
      best_rounds = R.rounds;
      best.reset();
    }
    if (worst.empty()) {
      R.reached = true;
      R.message = "every element within the tolerance";
      break;
    }
    if (R.rounds >= opt.max_rounds) {
      R.message = std::to_string(worst.size()) + " elements beyond the tolerance after " + std::to_string(R.rounds) + " rounds";
      break;
    }
    if (best_rounds == R.rounds) best = std::make_unique<std::pair<DecimateResult, LiftResult>>(dec, R.lift);
    // Split passes until every element beyond the tolerance is split itself (a LEPP path splits
    // its terminal edge first), before lifting again.
    t = Clock::now();
    EdgeSet features = edge_set(build_topology(dec.coarse.F, dec.coarse.num_vertices()), R.lift.coarse_edge_feature);
    int budget = 0, split = 0;
    for (int pass = 0; pass < 16 && !worst.empty(); ++pass) {
      budget = (max_faces - dec.coarse.num_faces()) / 2;  // a split adds 2 faces
      const SplitResult sr = split_coarse_edges(dec, edges_to_split(dec, worst, budget), opt.split);
      // A split of a feature edge puts its vertex on the dense curve: a curve vertex, both halves
      // feature edges.
      for (const auto& [a, b, m] : sr.vertices)
        if (features.erase(std::minmax(a, b))) {
          dec.coarse_vertex_feature[m] = 1;
          features.insert(std::minmax(a, m));
          features.insert(std::minmax(m, b));
        }
      split += sr.split;
      R.refused += sr.refused;
      if (sr.split == 0) break;
      const std::set<int> done(sr.faces.begin(), sr.faces.end());
      std::erase_if(worst, [&](int f) { return done.count(f) > 0; });
    }
    R.seconds_split += seconds_since(t);
    R.splits += split;
    if (split == 0) {
      R.message = std::to_string(worst.size()) + " elements beyond the tolerance: " +
                  (budget <= 0 ? "the face budget is spent" : "no edge of theirs may split");
      break;
    }
    ++R.rounds;
    if (lopt.progress) lopt.progress("refine round " + std::to_string(R.rounds), 1.0);
    t = Clock::now();
    R.lift = lift_coarse(fine, dec, quiet, &S);
    R.seconds_lift += seconds_since(t);
  }
  if (best && best_deviation < R.deviation_after) {
    R.message += "; kept round " + std::to_string(best_rounds) + " of " + std::to_string(R.rounds) + ", the closest";
    dec = std::move(best->first);
    R.lift = std::move(best->second);
    R.deviation_after = best_deviation;
  }
  R.message = (R.reached ? "reached: " : "tolerance not reached: ") + R.message + " (" + std::to_string(R.faces_before) +
              " -> " + std::to_string(dec.coarse.num_faces()) + " faces, " + std::to_string(R.splits) + " splits in " +
              std::to_string(R.rounds) + " rounds)";
  return R;
}

}  // namespace hocurve
