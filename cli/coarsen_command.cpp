// hocurve coarsen: decimate, map and lift a coarse curved mesh (coarse lifting issue).
#include "cli/command_options.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/coarse/decimate.hpp"
#include "engine/coarse/lift.hpp"
#include "engine/coarse/redecimate.hpp"
#include "engine/coarse/refine.hpp"
#include "engine/coarse/vertex_fans.hpp"
#include "engine/core/error.hpp"
#include "engine/highorder/validity.hpp"
#include "engine/highorder/write_msh.hpp"


#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

namespace hocurve::cli {

namespace {

const char* kCoarsenUsage =
    "usage: hocurve coarsen INPUT -o OUTPUT.msh (--faces N | --ratio R) [options]\n"
    "Decimates a linear triangle surface mesh to N triangles (or R x its count), keeping feature\n"
    "curves, and curves the coarse triangles to order P so that they stay on the dense surface.\n"
    "Where a few elements stray far more than the rest, the mesh is decimated again with the\n"
    "quadrics under them weighted up (--redecimate rounds); the closest round is kept.\n"
    "With --tolerance, while elements are further than F x the bounding-box diagonal from the\n"
    "input (both ways), the face count grows (re-decimated) and then they are split (longest-edge\n"
    "bisection on the dense surface), up to --max-faces; the round closest to the input is kept.\n";

nlohmann::json histogram(const std::vector<long long>& h) {
  nlohmann::json j = nlohmann::json::array();
  for (long long x : h) j.push_back(x);
  return j;
}

nlohmann::json decimation_json(const DecimateResult& d, double seconds) {
  const RejectCounts& r = d.rejected;
  return {{"target_faces", d.target_faces},
          {"faces", d.coarse.num_faces()},
          {"vertices", d.coarse.num_vertices()},
          {"reached_target", d.reached_target},
          {"message", d.message},
          {"collapses", d.collapses},
          {"deferred", d.deferred},
          {"rejected",
           {{"total", r.total()}, {"link", r.link}, {"feature", r.feature}, {"boundary", r.boundary},
            {"valence", r.valence}, {"fold", r.fold}, {"sliver", r.sliver}, {"flatten", r.flatten},
            {"deviation", r.deviation}}},
          {"feature_edges", d.feature_edges},
          {"corners", d.corners},
          {"fewest_faces", d.fewest_faces},
          {"map", {{"collapse_records", d.map.num_collapses()}, {"tracked_vertices", d.map.vertex_coarse_face.size()}}},
          {"seconds", {{"total", seconds}, {"flatten", d.seconds_flatten}, {"tracking", d.seconds_tracking}}}};
}

nlohmann::json lift_json(const LiftResult& l) {
  const ValidityReport& v = l.validity;
  return {{"order", l.mesh.order},
          {"vertices", l.vertices},
          {"faces", l.faces},
          {"edges", l.edges},
          {"dense_surface",
           {{"feature_edges", l.dense_feature_edges},
            {"corners", l.dense_corners},
            {"fits", l.dense_fits.fits.size()},
            {"degree_histogram", histogram(l.dense_fits.degree_histogram)},
            {"downgraded", l.dense_fits.downgraded},
            {"curve_fits", l.dense_curve_fits},
            {"support_points_used", l.dense_support}}},
          {"coarse_fits",
           {{"feature_edges", l.coarse_feature_edges},
            {"wedges", l.coarse_wedges},
            {"degree_histogram", histogram(l.coarse_degree_histogram)},
            {"mean_points", l.coarse_mean_points},
            {"min_points", l.coarse_min_points},
            {"grown_beyond_one_ring", l.coarse_grown}}},
          {"placement",
           {{"nodes", l.nodes},
            {"curve_nodes", l.curve_nodes},
            {"ray_fallbacks", l.ray_failed},
            {"map_clamped", l.map_clamped},
            {"walk_steps", l.walk_steps},
            {"refine_max_relative", l.refine_max},
            {"refine_rms_relative", l.refine_rms}}},
          {"validity",
           {{"checked", v.checked},
            {"fit_fallback_elements", l.fit_fallback_elements},
            {"slid_elements", l.slid_elements},
            {"slid_clusters", l.slid_clusters},
            {"invalid_before_repair", v.invalid_before},
            {"repaired", v.repaired},
            {"below_min_jacobian", v.below_floor_before},
            {"min_jacobian_repaired", v.quality_repaired},
            {"invalid_after", v.invalid_after},
            {"degenerate_input", v.degenerate_input},
            {"min_scaled_jacobian", v.min_scaled_jacobian}}},
          {"bbox_diagonal", l.bbox_diagonal},
          {"seconds",
           {{"dense_fits", l.seconds_dense},
            {"coarse_fits", l.seconds_coarse_fits},
            {"placement", l.seconds_placement},
            {"validity", l.seconds_validity},
            {"total", l.seconds_total}}}};
}

nlohmann::json redecimation_json(const RedecimateResult& r, const RedecimateOptions& o) {
  // Without rounds the deviations may never have been measured: null, not 0.
  auto measured = [&](double d) { return r.rounds == 0 && d == 0 ? nlohmann::json(nullptr) : nlohmann::json(d); };
  return {{"rounds_asked", o.rounds},
          {"rounds", r.rounds},
          {"kept_round", r.kept_round},
          {"straying_elements", r.straying},
          {"message", r.message},
          {"deviation_first_relative", measured(r.deviation_first)},
          {"deviation_kept_relative", measured(r.deviation_kept)},
          {"seconds", {{"decimate", r.seconds_decimate}, {"lift", r.seconds_lift}, {"measure", r.seconds_measure}}}};
}

nlohmann::json refinement_json(const RefineResult& r, const RefineOptions& o) {
  return {{"tolerance", o.tolerance},
          {"max_faces", o.max_faces},
          {"reached", r.reached},
          {"message", r.message},
          {"faces_before", r.faces_before},
          {"rounds", r.rounds},
          {"splits", r.splits},
          {"refused", r.refused},
          {"deviation_before_relative", r.deviation_before},
          {"deviation_after_relative", r.deviation_after},
          {"seconds", {{"measure", r.seconds_measure}, {"split", r.seconds_split}, {"lift", r.seconds_lift}}}};
}

}  // namespace

int run_coarsen(int argc, char** argv) {
  Args a = parse_command_line(argc, argv, kCoarsen);
  if (a.has("help")) {
    std::cout << command_help(kCoarsenUsage, kCoarsen);
    return 0;
  }
  if (a.positional.size() != 1) throw UsageError("coarsen needs exactly one INPUT file (see --help)");
  if (!a.has("output")) throw UsageError("coarsen needs -o OUTPUT.msh");
  if (a.has("faces") == a.has("ratio")) throw UsageError("coarsen needs exactly one of --faces N or --ratio R");
  OptionSettings o;
  apply_options(a, kCoarsen, o);
  const std::string input = a.positional[0], output = o.output;
  check_output_path("-o", output);
  if (!o.stats.empty()) check_output_path("--stats", o.stats);

  DecimateOptions& dopt = o.decimate;
  LiftOptions& lopt = o.lift;
  lopt.features = feature_options(dopt);
  const RefineOptions& ropt = o.refine;
  RedecimateOptions& rdo = o.redecimate;
  const MshOptions& msh = o.msh;
  const auto threads = thread_limit(o.threads);
  Progress progress{o.progress};
  // One 0..1 scale for the whole command: load 0-0.1, decimation 0.1-0.4, lifting 0.4-0.9, write 0.9-1.
  lopt.progress = [&](const std::string& stage, double f) {
    if (stage != "done") progress(stage, 0.4 + 0.5 * f);
  };

  const double t0 = now_seconds();
  LoadedInput in = load_input(input, progress, o.read);
  print_input_warnings("coarsen", in);
  const double t1 = now_seconds();
  progress("decimate", 0.1);
  // Non-manifold vertices (parts touching at a point): one pinned copy per fan of faces.
  const FanSplit split = split_vertex_fans(in.mesh);
  dopt.pinned_vertices = split.pinned;
  DecimateResult dec = decimate(split.mesh, dopt);
  const double t2 = now_seconds();
  progress("dense fits", 0.4);
  const DenseSurface dense = build_dense_surface(split.mesh, dense_surface_options(lopt));
  rdo.max_faces = ropt.max_faces > 0 ? ropt.max_faces : split.mesh.num_faces();
  RedecimateResult redecimated = redecimate_where_far(split.mesh, dopt, dec, lopt, dense, rdo);
  if (!dec.reached_target) std::cerr << "hocurve coarsen: warning: " << dec.message << "\n";
  const nlohmann::json decimation = decimation_json(dec, t2 - t1);  // the kept one, before any refinement splits
  const RefineResult refined = lift_and_refine(split.mesh, dec, lopt, ropt, &dense, &redecimated.lift);
  if (ropt.tolerance > 0 && !refined.reached) std::cerr << "hocurve coarsen: warning: " << refined.message << "\n";
  const LiftResult& lift = refined.lift;
  // The split parts meet again at their pinned copies: one vertex and one edge each, as in the input.
  HighOrderMesh result;
  ValidityReport rejoined;
  if (split.split_vertices > 0) {
    result = rejoin_vertex_copies(lift.mesh, coarse_vertex_copies(split, dec.coarse_vertex_origin));
    rejoined = repair_validity(result, lopt.validity);
  }
  const HighOrderMesh& out = split.split_vertices > 0 ? result : lift.mesh;
  const double t3 = now_seconds();
  progress("write", 0.9);
  write_msh_file(out, output, msh);
  const double t4 = now_seconds();
  progress("done", 1.0);

  if (!o.stats.empty()) {
    nlohmann::json s;
    s["generator"] = std::string("hocurve ") + HOCURVE_VERSION;
    s["input"] = input_json(input, in);
    s["decimation"] = decimation;
    s["decimation"]["split_vertices"] = split.split_vertices;
    s["decimation"]["nonmanifold_edges"] = split.nonmanifold_edges;
    s["lifting"] = lift_json(lift);
    s["redecimation"] = redecimation_json(redecimated, rdo);
    s["refinement"] = refinement_json(refined, ropt);
    s["rejoin"] = {{"vertices", lift.mesh.V.rows() - out.V.rows()},
                   {"invalid_before", rejoined.invalid_before},
                   {"repaired", rejoined.repaired},
                   {"invalid_after", rejoined.invalid_after}};
    s["output"] = {{"file", output},
                   {"format", msh.version == MshOptions::Version::V22 ? "msh22" : "msh41"},
                   {"binary", msh.binary},
                   {"order", out.order},
                   {"nodes", to_string(lift.mesh.distribution)},
                   {"elements", out.num_faces()},
                   {"bytes", std::filesystem::file_size(output)}};
    s["seconds"] = {{"load", t1 - t0}, {"decimate", t2 - t1}, {"lift", t3 - t2}, {"write", t4 - t3}, {"total", t4 - t0}};
    write_json_file(o.stats, s);
  }
  return 0;
}

}  // namespace hocurve::cli
