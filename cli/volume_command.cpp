// hocurve volume: curved tets filling a closed surface curved as `hocurve curve` curves it.
#include "cli/args.hpp"
#include "cli/command_options.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/stats_json.hpp"
#include "engine/volume/volume_mesh.hpp"
#include "engine/volume/write_tet_msh.hpp"


#include <filesystem>
#include <iostream>
#include <memory>

namespace hocurve::cli {

namespace {

// The surface is curved as `curve` curves it: curve's registry options (cli/option_registry.cpp),
// --order limited to 1..4 with default 2, plus the options of the tets alone, declared here.
std::vector<OptionSpec> volume_specs() {
  std::vector<OptionSpec> specs = command_specs(kCurve);
  specs.insert(specs.end(),
               {{"size", true, "target tet size inside (default: from the surface's edges)"},
                {"size-factor", true, "scales the tet sizes Gmsh derives (default 1)"},
                {"volume-name", true, "name of the volume's physical group (default fluid)"},
                {"optimize", true, "on (default: untangle and optimize the inside nodes, boundary fixed) | off"}});
  return specs;
}

const char* kVolumeUsage =
    "usage: hocurve volume INPUT -o OUTPUT.msh [--order P] [--size H | --size-factor F]\n"
    "                      [--format msh41|msh22] [--binary] [--stats STATS.json] [--threads N]\n"
    "Fills a closed, manifold surface (one or several shells) with order-P curved tets whose\n"
    "boundary is exactly `hocurve curve`'s surface; every tet is certified valid (Bernstein\n"
    "bounds of its Jacobian determinant).\n";

nlohmann::json quality_json(const TetMeshQuality& q) {
  return {{"tets", q.tets},
          {"invalid", q.invalid},
          {"min_scaled_jacobian", q.min_scaled_jacobian},
          {"p1_scaled_jacobian", q.p1_scaled_jacobian},
          {"sampled_min_scaled_jacobian", q.sampled_min_scaled_jacobian},
          {"sampled_p1_scaled_jacobian", q.sampled_p1_scaled_jacobian},
          {"min_jacobian_ratio", q.min_ratio}};
}

}  // namespace

int run_volume(int argc, char** argv) {
  const std::vector<OptionSpec> specs = volume_specs();
  const std::optional<Args> parsed = parse_command("volume", argc, argv, specs, kVolumeUsage);
  if (!parsed) return 0;
  const Args& a = *parsed;
  if (a.has("size") && a.has("size-factor")) throw UsageError("volume takes --size or --size-factor, not both");
  const std::string input = a.positional[0], output = a.get("output");

  for (const char* curve_only : {"method", "nodes"})
    if (a.has(curve_only)) throw UsageError(std::string("volume takes no --") + curve_only + " (curve only)");
  OptionSettings o;
  apply_options(a, kCurve, o);
  VolumeOptions opt;
  opt.curve = o.curve;
  opt.curve.order = static_cast<int>(a.get_int("order", 2, 1, 4));
  opt.tets.size = a.get_double("size", 0, 1e-300, 1e300);
  opt.tets.size_factor = a.get_double("size-factor", 1, 1e-6, 1e6);
  opt.optimize_enabled = a.get_choice("optimize", "on", {"on", "off"}) == "on";
  TetMshOptions msh;
  msh.msh = o.msh;
  msh.volume_name = a.get("volume-name", "fluid");
  if (msh.volume_name.empty() || msh.volume_name.find('"') != std::string::npos)
    throw UsageError("--volume-name must be non-empty and hold no '\"'");
  const auto threads = thread_limit(o.threads);
  Progress progress{o.progress};
  opt.curve.progress = [&](const std::string& stage, double f) { progress(stage, 0.1 + 0.4 * f); };

  const double t0 = now_seconds();
  LoadedInput in = load_input(input, progress, o.read);
  print_input_warnings("volume", in);
  const double t1 = now_seconds();
  progress("volume", 0.1);
  VolumeResult res = volume_mesh(in.mesh, opt);
  const double t2 = now_seconds();
  progress("write", 0.9);
  write_tet_msh_file(res.mesh, output, msh);
  const double t3 = now_seconds();
  progress("done", 1.0);
  if (res.quality.invalid)
    std::cerr << "hocurve volume: warning: " << res.quality.invalid << " of " << res.quality.tets
              << " tets not certified valid (first: tet " << res.quality.invalid_tets.front() << ")\n";

  if (a.has("stats")) {
    nlohmann::json s;
    s["generator"] = std::string("hocurve ") + HOCURVE_VERSION;
    s["input"] = input_json(input, in);
    s["curving"] = stats_json(res.curve);
    s["volume"] = {{"shells", res.shells},
                   {"order", res.mesh.order},
                   {"nodes", res.mesh.X.rows()},
                   {"gmsh_tets", res.linear_tets},
                   {"split_cap_edges", res.split_edges},
                   {"invalid_before", res.invalid_before},
                   {"optimize", {{"poor_before", res.optimize.poor_before},
                                 {"tangled_before", res.optimize.tangled_before},
                                 {"poor_after", res.optimize.poor_after},
                                 {"free_nodes", res.optimize.free_nodes},
                                 {"sweeps", res.optimize.sweeps}}},
                   {"final", quality_json(res.quality)}};
    s["output"] = {{"file", output},
                   {"format", msh.msh.version == MshOptions::Version::V22 ? "msh22" : "msh41"},
                   {"binary", msh.msh.binary},
                   {"bytes", std::filesystem::file_size(output)}};
    s["seconds"] = {{"load", t1 - t0},       {"shells", res.shells_seconds},
                    {"curve", res.curve_seconds},  {"tets", res.tets_seconds},
                    {"elevate", res.elevate_seconds}, {"check_before", res.check_before_seconds},
                    {"smooth", res.smooth_seconds},
                    {"optimize", res.optimize.seconds}, {"check", res.check_seconds},
                    {"volume", t2 - t1},     {"write", t3 - t2},
                    {"total", t3 - t0}};
    write_json_file(o.stats, s);
  }
  return res.quality.invalid ? 4 : 0;
}

}  // namespace hocurve::cli
