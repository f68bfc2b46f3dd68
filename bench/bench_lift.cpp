// Coarse lifting benchmark (issue 5): accuracy of coarse curved meshes against the exact
// surface (analytic inputs) and against the dense input (shared meshes), and timings.
// Usage: bench_lift [all | analytic | real | speed] [order]
//        bench_lift FILE RATIO [order]   (one mesh)
// BENCH_LIFT_PROJECTION=ray|closest picks LiftOptions::projection (default: the
// library default), to compare the node projections on one binary. See bench/LIFT.md.
#include "engine/coarse/decimate.hpp"
#include "engine/coarse/lift.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/io/read_mesh.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>

using namespace hocurve;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// One coarsening run: decimation (with the map), lifting, and the time split of issue 5
/// (decimate = collapses and quadrics, map = flattening + tracking of the fine vertices).
struct Run {
  DecimateResult dec;
  LiftResult lift;
  double decimate = 0, map = 0, lift_seconds = 0;
};

LiftOptions::Projection projection_from_env(LiftOptions::Projection fallback) {
  const char* e = std::getenv("BENCH_LIFT_PROJECTION");
  if (!e) return fallback;
  const std::string s = e;
  if (s == "ray") return LiftOptions::Projection::Ray;
  if (s == "closest") return LiftOptions::Projection::Closest;
  throw std::runtime_error("BENCH_LIFT_PROJECTION must be ray or closest, not " + s);
}

/// The lifting options of every bench run: the decimation's features, the projection from the
/// environment.
LiftOptions lift_options(const DecimateOptions& dopt, int p) {
  LiftOptions lopt;
  lopt.order = p;
  lopt.features = feature_options(dopt);
  lopt.projection = projection_from_env(lopt.projection);
  return lopt;
}

Run coarsen(const Mesh& fine, const DecimateOptions& dopt, int p) {
  Run r;
  const double t0 = now();
  r.dec = decimate(fine, dopt);
  const double t1 = now();
  r.map = r.dec.seconds_flatten + r.dec.seconds_tracking;
  r.decimate = (t1 - t0) - r.map;
  r.lift = lift_coarse(fine, r.dec, lift_options(dopt, p));
  r.lift_seconds = now() - t1;
  return r;
}

double max_abs(const Eigen::MatrixXd& P, const std::function<double(const Eigen::Vector3d&)>& dist) {
  double m = 0;
  for (Eigen::Index i = 0; i < P.rows(); ++i) m = std::max(m, std::abs(dist(P.row(i).transpose())));
  return m;
}

void analytic(const char* name, const Mesh& fine, int target, int p,
              const std::function<double(const Eigen::Vector3d&)>& dist) {
  DecimateOptions dopt;
  dopt.target_faces = target;
  const Run r = coarsen(fine, dopt, p);
  const DecimateResult& D = r.dec;
  const LiftResult& L = r.lift;
  LiftOptions lopt = lift_options(dopt, p);
  lopt.refine = false;
  const LiftResult Lf = lift_coarse(fine, D, lopt);
  const double dense = max_abs(sample_faces(fine, 8), dist);
  const double straight = max_abs(sample_faces(D.coarse, 12), dist);
  const double curved = max_abs(tessellate(L.mesh, 12).V, dist);
  const double fits_only = max_abs(tessellate(Lf.mesh, 12).V, dist);
  std::printf("%-8s %6d -> %4d P%d | max distance to exact: dense linear %.2e, straight coarse %.2e, coarse P%d %.2e "
              "(fits only %.2e; P%d/dense %.2f) | invalid %lld (repaired %lld), min J %.2f | decimate %.2f s, map %.2f s, "
              "lift %.2f s\n",
              name, fine.num_faces(), D.coarse.num_faces(), p, dense, straight, p, curved, fits_only, p, curved / dense,
              L.validity.invalid_after, L.validity.repaired, L.validity.min_scaled_jacobian, r.decimate, r.map,
              r.lift_seconds);
  std::printf("         coarse fits: mean %.1f points (min %d), %lld grown; refine move max %.2e rms %.2e diag; "
              "%lld fit fallbacks, %lld curve nodes, %lld rays failed, %lld clamps, %.2f walk steps/node\n",
              L.coarse_mean_points, L.coarse_min_points, L.coarse_grown, L.refine_max, L.refine_rms, L.fit_fallback_elements, L.curve_nodes,
              L.ray_failed, L.map_clamped, double(L.walk_steps) / std::max<long long>(1, L.nodes));
}

void real(const std::string& file, double ratio, int p) {
  const Mesh fine = read_mesh_file(file).mesh;
  DecimateOptions dopt;
  dopt.target_ratio = ratio;
  const Run r = coarsen(fine, dopt, p);
  const DecimateResult& D = r.dec;
  const LiftResult& L = r.lift;
  LiftOptions lopt = lift_options(dopt, p);
  const double diag = L.bbox_diagonal;
  const HausdorffResult Hc = hausdorff_distance(fine, tessellate(L.mesh, 8), 4);
  const HausdorffResult Hs = hausdorff_distance(fine, D.coarse, 4);
  std::printf("%-22s %7d -> %5d P%d | Hausdorff/diag: coarse P%d %.3f%% (dense->coarse %.3f%%, coarse->dense %.3f%%), "
              "straight %.3f%% | invalid %lld (fit fallback %lld, repaired %lld) | features dense %lld, coarse %lld | "
              "decimate %.2f s, map %.2f s, lift %.2f s\n",
              file.substr(file.find_last_of('/') + 1).c_str(), fine.num_faces(), D.coarse.num_faces(), p, p,
              100 * Hc.hausdorff() / diag, 100 * Hc.a_to_b / diag, 100 * Hc.b_to_a / diag, 100 * Hs.hausdorff() / diag,
              L.validity.invalid_after, L.fit_fallback_elements, L.validity.repaired, L.dense_feature_edges, L.coarse_feature_edges,
              r.decimate, r.map, r.lift_seconds);
  if (!D.reached_target) std::printf("    %s\n", D.message.c_str());
  if (std::getenv("BENCH_LIFT_DEBUG")) {
    lopt.repair = false;
    const LiftResult U = lift_coarse(fine, D, lopt);
    const HausdorffResult Hu = hausdorff_distance(fine, tessellate(U.mesh, 8), 4);
    lopt.refine = false;
    const LiftResult Uf = lift_coarse(fine, D, lopt);
    const HausdorffResult Hf = hausdorff_distance(fine, tessellate(Uf.mesh, 8), 4);
    std::printf("    unrepaired: %lld invalid, Hausdorff %.3f%% (%.3f / %.3f); fits only unrepaired: %lld invalid, %.3f%%\n",
                U.validity.invalid_after, 100 * Hu.hausdorff() / diag, 100 * Hu.a_to_b / diag, 100 * Hu.b_to_a / diag,
                Uf.validity.invalid_after, 100 * Hf.hausdorff() / diag);
  }
}

void speed(int p) {
  const Mesh fine = torus_grid(500, 200, 1.0, 0.4);
  DecimateOptions dopt;
  dopt.target_ratio = 0.04;
  const Run r = coarsen(fine, dopt, p);
  const LiftResult& L = r.lift;
  std::printf("speed: torus %d -> %d P%d: decimate %.2f s, map %.2f s (flatten %.2f, tracking %.2f), lift %.2f s "
              "(dense fits %.2f, coarse fits %.2f, placement %.2f, validity %.2f), total %.2f s; invalid %lld\n",
              fine.num_faces(), r.dec.coarse.num_faces(), p, r.decimate, r.map, r.dec.seconds_flatten,
              r.dec.seconds_tracking, r.lift_seconds, L.seconds_dense, L.seconds_coarse_fits, L.seconds_placement,
              L.seconds_validity, r.decimate + r.map + r.lift_seconds, L.validity.invalid_after);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string what = argc >= 2 ? argv[1] : "all";
    if (argc >= 3 && what != "all" && what != "analytic" && what != "real" && what != "speed") {
      real(what, std::stod(argv[2]), argc >= 4 ? std::stoi(argv[3]) : 4);
      return 0;
    }
    const int p = argc >= 3 ? std::stoi(argv[2]) : 4;
    if (what == "all" || what == "analytic") {
      analytic("sphere", uv_sphere(60, 100), 500, p, sphere_distance);
      analytic("torus", torus_grid(125, 60, 1.0, 0.4), 640, p, [](const Eigen::Vector3d& x) { return torus_distance(x, 1.0, 0.4); });
    }
    if (what == "all" || what == "real") {
      const std::string dir = std::string(HOCURVE_SHARED_DIR) + "/meshes/";
      // The organic meshes of issue 5, then the CAD exports (sharp features, fans of needles).
      for (const char* f : {"bunny_closed.obj", "armadillo.obj", "skull_lowres.obj", "spot.obj", "hinge_netgen.stl",
                            "lever_solidedge.stl", "t13_data.stl", "ktoolcav.stl", "king_ascii.stl.gz"})
        real(dir + f, 0.04, p);
    }
    if (what == "all" || what == "speed") speed(p);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_lift: %s\n", e.what());
    return 1;
  }
  return 0;
}
