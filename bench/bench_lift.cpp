// Coarse lifting benchmark (issue 5): accuracy of coarse curved meshes against the exact
// surface (analytic inputs) and against the dense input (shared meshes), and timings.
// Usage: bench_lift [all | analytic | real | speed | refine] [order]
//        bench_lift FILE RATIO [order]   (one mesh)
// BENCH_LIFT_PROJECTION=ray|closest picks LiftOptions::projection (default: the
// library default), to compare the node projections on one binary; BENCH_LIFT_RESNAP=0|1 and
// BENCH_LIFT_OFFENDING=0|1 set LiftOptions::resnap_invalid and fallback_offending_only.
// BENCH_LIFT_DEBUG=1 adds the unrepaired figures and why snapped elements are invalid. See
// bench/LIFT.md.
#include "engine/coarse/decimate.hpp"
#include "engine/coarse/lift.hpp"
#include "engine/coarse/redecimate.hpp"
#include "engine/coarse/refine.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/curving/test_meshes.hpp"
#include "engine/highorder/bezier.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/validity.hpp"
#include "engine/io/read_mesh.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
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
  std::string refine;  ///< lift_and_refine's message (BENCH_LIFT_TOL)
  std::string redecimate;  ///< redecimate_where_far's message
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
  if (const char* e = std::getenv("BENCH_LIFT_RESNAP")) lopt.resnap_invalid = std::string(e) != "0";
  if (const char* e = std::getenv("BENCH_LIFT_SLIDE")) lopt.slide_candidates = std::string(e) != "0";
  if (const char* e = std::getenv("BENCH_LIFT_OFFENDING")) lopt.fallback_offending_only = std::string(e) != "0";
  return lopt;
}

/// BENCH_LIFT_DEFER overrides DecimateOptions::defer_deviation (0: plain quadric order).
Run coarsen(const Mesh& fine, DecimateOptions dopt, int p) {
  if (const char* e = std::getenv("BENCH_LIFT_DEFER")) dopt.defer_deviation = std::atof(e);
  if (const char* e = std::getenv("BENCH_LIFT_MAXDEV")) dopt.max_deviation = std::atof(e);
  Run r;
  const double t0 = now();
  r.dec = decimate(fine, dopt);
  const double t1 = now();
  r.map = r.dec.seconds_flatten + r.dec.seconds_tracking;
  r.decimate = (t1 - t0) - r.map;
  const LiftOptions lopt = lift_options(dopt, p);
  const DenseSurface S = build_dense_surface(fine, dense_surface_options(lopt));
  RedecimateOptions rdo;
  if (const char* e = std::getenv("BENCH_LIFT_REDECIMATE")) rdo.rounds = std::atoi(e);
  if (const char* e = std::getenv("BENCH_LIFT_TOL")) rdo.tolerance = std::atof(e);
  if (const char* m = std::getenv("BENCH_LIFT_MAXRATIO")) rdo.max_faces = static_cast<int>(std::atof(m) * fine.num_faces());
  if (std::getenv("BENCH_LIFT_NOGROW")) rdo.max_faces = 0;
  RedecimateResult rd = redecimate_where_far(fine, dopt, r.dec, lopt, S, rdo);
  r.redecimate = rd.message;
  if (const char* e = std::getenv("BENCH_LIFT_TOL")) {
    RefineOptions ro;
    ro.tolerance = std::atof(e);
    if (const char* m = std::getenv("BENCH_LIFT_MAXRATIO")) ro.max_faces = static_cast<int>(std::atof(m) * fine.num_faces());
    RefineResult rr = lift_and_refine(fine, r.dec, lopt, ro, &S, &rd.lift);
    r.lift = std::move(rr.lift);
    char buf[200];
    std::snprintf(buf, sizeof buf, " [largest element deviation %.3f%% -> %.3f%%; measure %.2f s, split %.2f s, lift %.2f s]",
                  100 * rr.deviation_before, 100 * rr.deviation_after, rr.seconds_measure, rr.seconds_split, rr.seconds_lift);
    r.refine = rr.message + buf;
  } else {
    r.lift = std::move(rd.lift);
  }
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

/// Why snapped elements are invalid (BENCH_LIFT_DEBUG): compares the unrepaired snapped mesh
/// `snap` with the unrepaired fit-blend mesh `fit` (same corners). Per element invalid when
/// snapped, which node groups must go back to the fit blend to make it valid (face nodes only,
/// one edge's nodes, all edge nodes, all), where the lowest Bernstein coefficient of J sits
/// (corner, edge, interior), and the snap move of the nodes split into the component along the
/// straight triangle's normal and the tangential rest, in straight mean edge lengths.
void diagnose_invalid(const HighOrderMesh& snap, const HighOrderMesh& fit) {
  const int p = snap.order, nf = snap.num_faces(), npe = snap.nodes_per_edge(), npf = snap.nodes_per_face();
  const JacobianBasis basis(p);
  ValidityOptions vopt;
  auto valid = [&](const Eigen::MatrixXd& X) { return check_element(basis, X, vopt).valid; };
  long long bad = 0, fit_bad = 0, by_face = 0, by_one_edge = 0, by_edges = 0, by_all = 0, at_corner = 0, at_edge = 0;
  // [valid 0 / invalid 1][edge 0 / face 1]: sums of normal and tangential move / h, and counts
  double sn[2][2] = {}, st[2][2] = {}, mx_t[2][2] = {}, cnt[2][2] = {};
  double min_angle[2] = {}, nface[2] = {};
  for (int f = 0; f < nf; ++f) {
    const Eigen::MatrixXd S = element_nodes(snap, f), F = element_nodes(fit, f);
    const bool ok = valid(S);
    fit_bad += !valid(F);
    const int b = ok ? 0 : 1;
    const Eigen::Vector3d a = S.row(0), c1 = S.row(1), c2 = S.row(2);
    const Eigen::Vector3d n = (c1 - a).cross(c2 - a).normalized();
    const double h = ((c1 - a).norm() + (c2 - c1).norm() + (a - c2).norm()) / 3;
    double amin = M_PI;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d x = S.row(j), y = S.row((j + 1) % 3), z = S.row((j + 2) % 3);
      amin = std::min(amin, std::acos(std::clamp((y - x).normalized().dot((z - x).normalized()), -1.0, 1.0)));
    }
    min_angle[b] += amin * 180 / M_PI, nface[b] += 1;
    for (int i = 3; i < S.rows(); ++i) {
      const int g = i < 3 + 3 * npe ? 0 : 1;
      const Eigen::Vector3d d = (S.row(i) - F.row(i)).transpose();
      const double dn = std::abs(d.dot(n)) / h, dt = (d - d.dot(n) * n).norm() / h;
      sn[b][g] += dn, st[b][g] += dt, mx_t[b][g] = std::max(mx_t[b][g], dt), cnt[b][g] += 1;
    }
    if (ok) continue;
    ++bad;
    const Eigen::VectorXd J = jacobian_bezier(basis, S);
    Eigen::Index m = 0;
    J.minCoeff(&m);
    const int d = basis.d;
    int a1 = 0, a2 = 0;
    for (int k = 0, q = 0; k <= d; ++k)
      for (int l = 0; l + k <= d; ++l, ++q)
        if (bernstein_index(d, l, k) == m) a1 = l, a2 = k;
    const int a0 = d - a1 - a2;
    if (a0 == d || a1 == d || a2 == d) ++at_corner;
    else if (a0 == 0 || a1 == 0 || a2 == 0) ++at_edge;
    auto with = [&](int lo, int hi) {
      Eigen::MatrixXd X = S;
      X.middleRows(lo, hi - lo) = F.middleRows(lo, hi - lo);
      return valid(X);
    };
    if (npf > 0 && with(3 + 3 * npe, 3 + 3 * npe + npf)) ++by_face;
    else if (with(3, 3 + npe) || with(3 + npe, 3 + 2 * npe) || with(3 + 2 * npe, 3 + 3 * npe)) ++by_one_edge;
    else if (with(3, 3 + 3 * npe)) ++by_edges;
    else if (with(3, 3 + 3 * npe + npf)) ++by_all;
  }
  std::printf("    invalid snapped %lld / %d (fit blend %lld); made valid by the fit blend of: face nodes %lld, one edge %lld, "
              "all edges %lld, all nodes %lld, none %lld; min J coefficient at a corner %lld, on an edge %lld, inside %lld\n",
              bad, nf, fit_bad, by_face, by_one_edge, by_edges, by_all, bad - by_face - by_one_edge - by_edges - by_all,
              at_corner, at_edge, bad - at_corner - at_edge);
  for (int b = 0; b < 2; ++b)
    std::printf("    %s elements: min angle %.1f deg; snap move / h: edge nodes normal %.3f tangential %.3f (max %.3f), "
                "face nodes normal %.3f tangential %.3f (max %.3f)\n",
                b ? "invalid" : "valid  ", min_angle[b] / std::max(1.0, nface[b]), sn[b][0] / std::max(1.0, cnt[b][0]),
                st[b][0] / std::max(1.0, cnt[b][0]), mx_t[b][0], sn[b][1] / std::max(1.0, cnt[b][1]),
                st[b][1] / std::max(1.0, cnt[b][1]), mx_t[b][1]);
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
              "straight %.3f%% | invalid %lld (resnapped %lld, fit fallback %lld, slid %lld in %lld clusters, repaired %lld) | features dense %lld, coarse %lld | "
              "decimate %.2f s, map %.2f s, lift %.2f s\n",
              file.substr(file.find_last_of('/') + 1).c_str(), fine.num_faces(), D.coarse.num_faces(), p, p,
              100 * Hc.hausdorff() / diag, 100 * Hc.a_to_b / diag, 100 * Hc.b_to_a / diag, 100 * Hs.hausdorff() / diag,
              L.validity.invalid_after, L.resnapped_elements, L.fit_fallback_elements, L.slid_elements, L.slid_clusters, L.validity.repaired, L.dense_feature_edges, L.coarse_feature_edges,
              r.decimate, r.map, r.lift_seconds);
  if (!D.reached_target) std::printf("    %s\n", D.message.c_str());
  std::printf("    redecimate: %s\n", r.redecimate.c_str());
  if (!r.refine.empty()) std::printf("    refine: %s\n", r.refine.c_str());
  if (std::getenv("BENCH_LIFT_ELEMENTS")) {
    const double t0 = now();
    const std::vector<double> dev = element_deviation(L.mesh, fine);
    std::printf("    element_deviation: %.3f s\n", now() - t0);
    std::printf("    element deviation max %.3f%%; elements above", 100 * *std::max_element(dev.begin(), dev.end()) / diag);
    for (double t : {0.3, 0.4, 0.5, 0.7})
      std::printf(" %.1f%%: %ld", t, std::count_if(dev.begin(), dev.end(), [&](double x) { return x > t * diag / 100; }));
    std::printf("\n");
  }
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
    std::printf("    %lld nodes, %lld curve nodes, %lld rays fell back to the closest point\n", U.nodes, U.curve_nodes,
                U.ray_failed);
    diagnose_invalid(U.mesh, Uf.mesh);
    // Where the curved surface is furthest from the input: the worst node, and how far the
    // snap moved it from its fit-blend position.
    const TriangleGrid G = build_triangle_grid(fine);
    double worst = 0;
    int wf = -1;
    for (int f = 0; f < L.mesh.num_faces(); ++f) {
      const Eigen::MatrixXd X = element_nodes(L.mesh, f);
      for (Eigen::Index i = 0; i < X.rows(); ++i) {
        const double d = grid_distance(G, X.row(i).transpose());
        if (d > worst) worst = d, wf = f;
      }
    }
    {
      double wu = 0; int fu = -1, iu = -1;
      for (int f = 0; f < U.mesh.num_faces(); ++f) {
        const Eigen::MatrixXd X = element_nodes(U.mesh, f);
        for (Eigen::Index i = 0; i < X.rows(); ++i) {
          const double d = grid_distance(G, X.row(i).transpose());
          if (d > wu) wu = d, fu = f, iu = i;
        }
      }
      const Eigen::MatrixXd X = element_nodes(U.mesh, fu), Xf = element_nodes(Uf.mesh, fu);
      std::printf("    unrepaired worst node: element %d node %d, %.3f%% off; nodes:", fu, iu, 100 * wu / diag);
      for (Eigen::Index i = 0; i < X.rows(); ++i)
        std::printf(" %.2f/%.2f", 100 * grid_distance(G, X.row(i).transpose()) / diag, 100 * (X.row(i) - Xf.row(i)).norm() / diag);
      std::printf("\n");
    }
    {
      // The element whose surface strays furthest from the input (samples, not nodes).
      const Eigen::MatrixXd uv = bernstein_lattice(8);
      double ws = 0;
      int fs = -1;
      for (int f = 0; f < L.mesh.num_faces(); ++f) {
        const Eigen::MatrixXd S = evaluate_triangle(element_nodes(L.mesh, f), p, uv);
        for (Eigen::Index i = 0; i < S.rows(); ++i) {
          const double d = grid_distance(G, S.row(i).transpose());
          if (d > ws) ws = d, fs = f;
        }
      }
      if (fs >= 0) {
        const Eigen::MatrixXd X = element_nodes(L.mesh, fs);
        std::printf("    worst element (samples): %d, %.3f%% off; node distances %%:", fs, 100 * ws / diag);
        for (Eigen::Index i = 0; i < X.rows(); ++i) std::printf(" %.2f", 100 * grid_distance(G, X.row(i).transpose()) / diag);
        std::printf("; min J %.3f\n", check_element(X, p).min_scaled_jacobian);
      }
    }
    if (wf >= 0) {
      const Eigen::MatrixXd X = element_nodes(L.mesh, wf), Xf = element_nodes(Uf.mesh, wf);
      std::printf("    worst node: element %d, %.3f%% off the input; its nodes (distance %% / snap move %%):", wf,
                  100 * worst / diag);
      for (Eigen::Index i = 0; i < X.rows(); ++i)
        std::printf(" %.2f/%.2f", 100 * grid_distance(G, X.row(i).transpose()) / diag, 100 * (X.row(i) - Xf.row(i)).norm() / diag);
      std::printf("\n    corners:");
      for (int j = 0; j < 3; ++j) std::printf(" (%.4g %.4g %.4g)", X(j, 0), X(j, 1), X(j, 2));
      std::printf("\n");
    }
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
    if (argc >= 3 && what != "all" && what != "analytic" && what != "real" && what != "speed" && what != "refine") {
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
    if (what == "refine") {
      // The organic meshes of issue 5 from 2%, 3% and 4%, refined to 0.5% within 5% of the faces
      // (unless BENCH_LIFT_TOL / BENCH_LIFT_MAXRATIO say otherwise).
      setenv("BENCH_LIFT_TOL", "0.005", 0);
      setenv("BENCH_LIFT_MAXRATIO", "0.05", 0);
      const std::string dir = std::string(HOCURVE_SHARED_DIR) + "/meshes/";
      for (double ratio : {0.02, 0.03, 0.04})
        for (const char* f : {"bunny_closed.obj", "armadillo.obj", "skull_lowres.obj", "spot.obj"}) real(dir + f, ratio, p);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_lift: %s\n", e.what());
    return 1;
  }
  return 0;
}
