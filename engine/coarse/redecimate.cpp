#include "engine/coarse/redecimate.hpp"

#include "engine/coarse/surface_distance.hpp"
#include "engine/core/stopwatch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace hocurve {

namespace {

/// A dense vertex's weight never exceeds this: a region that stays far whatever it gets would
/// otherwise pin ever more of the budget round after round.
constexpr double kMaxWeight = 100;

double largest(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

RedecimateResult redecimate_where_far(const Mesh& fine, const DecimateOptions& dopt, DecimateResult& dec,
                                      const LiftOptions& lopt, const DenseSurface& dense,
                                      const RedecimateOptions& opt) {
  RedecimateResult R;
  // Progress: the first lifting and each planned round take an equal share of lopt's 0..1 (rounds
  // of a grown face count report 1).
  const double share = 1.0 / (1 + std::max(0, opt.rounds));
  LiftOptions first = lopt;
  if (lopt.progress)
    first.progress = [&](const std::string& stage, double f) {
      if (stage != "done") lopt.progress(stage, share * f);
    };
  auto t = Clock::now();
  R.lift = lift_coarse(fine, dec, first, &dense);
  R.seconds_lift += seconds_since(t);
  if (opt.rounds <= 0 || !dopt.build_map) {  // nothing to measure for
    R.message = "no re-decimation asked";
    return R;
  }
  if (dec.collapses == 0) {  // the input itself (a target at or above its count): every round is the same
    R.message = "nothing was decimated: no re-decimation";
    return R;
  }
  const long long faces = dec.coarse.num_faces();
  if (opt.max_missed_target > 0 && !dec.reached_target && faces > opt.max_missed_target * dec.target_faces) {
    R.message = "the decimation stopped at " + std::to_string(faces) + " faces, over " +
                std::to_string(static_cast<long long>(opt.max_missed_target)) + "x its target " +
                std::to_string(dec.target_faces) + ": no re-decimation";
    return R;
  }
  // Straying elements, and whether they are few: first on a rough sample (the share barely depends
  // on it, and on large smooth meshes the full measure costs more than the lifting).
  auto count_straying = [&](const std::vector<double>& dev) {
    const double target = opt.target_fraction * largest(dev);
    return static_cast<int>(std::count_if(dev.begin(), dev.end(), [&](double d) { return d > target; }));
  };
  t = Clock::now();
  const int nf = R.lift.mesh.num_faces();
  R.straying = count_straying(element_deviation(R.lift.mesh, fine, 4, 1));
  const bool even = R.straying > opt.max_straying_share * nf;
  if (!even) R.deviation = element_deviation(R.lift.mesh, fine);
  R.seconds_measure += seconds_since(t);
  if (even) {
    R.message = std::to_string(R.straying) + " of " + std::to_string(nf) +
                " elements beyond half the largest deviation (rough sample): the error is even, no re-decimation";
    return R;
  }
  const double diag = R.lift.bbox_diagonal;
  double best = largest(R.deviation);
  R.deviation_first = R.deviation_kept = best / diag;
  const double target = opt.target_fraction * best;
  R.straying = count_straying(R.deviation);
  char line[160];
  std::snprintf(line, sizeof line, "%d of %d elements beyond %.0f%% of the largest deviation (%.3g%% of the diagonal)",
                R.straying, nf, 100 * opt.target_fraction, 100 * R.deviation_first);
  R.message = line;
  if (best <= opt.tolerance * diag || R.straying == 0 || R.straying > opt.max_straying_share * nf) {
    R.message += R.straying > opt.max_straying_share * nf ? ": the error is even, no re-decimation"
                                                           : ": no re-decimation needed";
    return R;
  }

  std::vector<double> weight(fine.num_vertices(), 1.0);
  auto weigh = [&](const CoarseMap& map, const std::vector<double>& dev) {
    for (int v = 0; v < fine.num_vertices(); ++v) {
      const int f = map.vertex_coarse_face[v];
      if (f >= 0 && dev[f] > target) weight[v] = std::min(kMaxWeight, weight[v] * (dev[f] / target) * (dev[f] / target));
    }
  };
  weigh(dec.map, R.deviation);
  LiftOptions quiet = lopt;  // the rounds do not report the lifting's stages again
  quiet.progress = nullptr;
  // The face count of the rounds: the decimation's, grown while the tolerance is out of reach.
  DecimateOptions o = dopt;
  o.target_faces = dec.target_faces;
  const int first_faces = dec.coarse.num_faces();
  const bool may_grow = opt.tolerance > 0 && opt.max_faces > first_faces;
  for (int at_count = 0;; ++at_count) {
    if (best <= opt.tolerance * diag) break;
    if (at_count == opt.rounds) {
      const int from = std::max(o.target_faces, first_faces);  // an unreached target: what was reached
      const int grown = std::min(opt.max_faces, static_cast<int>(std::ceil(opt.growth * from)));
      if (!may_grow || grown <= from) break;
      o.target_faces = grown;
      at_count = 0;
    }
    ++R.rounds;
    o.vertex_weight = weight;
    t = Clock::now();
    DecimateResult d = decimate(fine, o);
    R.seconds_decimate += seconds_since(t);
    t = Clock::now();
    LiftResult L = lift_coarse(fine, d, quiet, &dense);
    R.seconds_lift += seconds_since(t);
    t = Clock::now();
    std::vector<double> dev = element_deviation(L.mesh, fine);
    R.seconds_measure += seconds_since(t);
    weigh(d.map, dev);
    // Never more faces than asked for, or than the first decimation had where that was out of reach.
    if (largest(dev) < best && d.coarse.num_faces() <= std::max(first_faces, o.target_faces)) {
      best = largest(dev);
      dec = std::move(d);
      R.lift = std::move(L);
      R.deviation = std::move(dev);
      R.kept_round = R.rounds;
    }
    if (lopt.progress) lopt.progress("re-decimate round " + std::to_string(R.rounds), std::min(1.0, (1 + R.rounds) * share));
  }
  R.deviation_kept = best / diag;
  std::snprintf(line, sizeof line, "; %d re-decimations, kept round %d: %.3g%% (%d faces)", R.rounds, R.kept_round,
                100 * R.deviation_kept, dec.coarse.num_faces());
  R.message += line;
  return R;
}

}  // namespace hocurve
