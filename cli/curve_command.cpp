// hocurve curve: dense curving of a linear surface mesh into a high-order .msh.
#include "cli/args.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"
#include "cli/curve_options.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stats_json.hpp"
#include "engine/highorder/write_msh.hpp"

#include <filesystem>
#include <iostream>
#include <memory>

namespace hocurve::cli {

namespace {

// The shared options plus curve's own: --method and --nodes.
std::vector<OptionSpec> curve_specs() {
  std::vector<OptionSpec> specs = curve_option_specs("element order 1..6 (default 4)");
  specs.insert(specs.begin() + 2,
               {{"method", true, "solf (default: fitted surface) | linear (nodes on the flat facets)"},
                {"nodes", true, "equispaced (default; what Gmsh's Lagrange elements assume) | lobatto"}});
  return specs;
}

const char* kCurveUsage =
    "usage: hocurve curve INPUT -o OUTPUT.msh [--order P] [--nodes equispaced|lobatto]\n"
    "                     [--format msh41|msh22] [--binary] [--stats STATS.json] [--threads N]\n"
    "Curves a linear triangle surface mesh (STL, OBJ, PLY, OFF, MSH; optionally .gz) into\n"
    "order-P curved triangles on a surface reconstructed from local least-squares fits.\n";

}  // namespace

int run_curve(int argc, char** argv) {
  const std::vector<OptionSpec> specs = curve_specs();
  const std::optional<Args> parsed = parse_command("curve", argc, argv, specs, kCurveUsage);
  if (!parsed) return 0;
  const Args& a = *parsed;
  const std::string input = a.positional[0], output = a.get("output");

  CurveOptions opt = parse_curve_options(a, 6);
  opt.method = a.get_choice("method", "solf", {"solf", "linear"}) == "linear" ? CurveOptions::Method::Linear
                                                                             : CurveOptions::Method::Solf;
  opt.distribution = parse_node_distribution(a.get_choice("nodes", "equispaced", {"equispaced", "lobatto"}));
  const MshOptions msh = parse_msh_options(a);
  const auto threads = thread_limit(a);
  Progress progress{a.has("progress")};
  // One 0..1 scale for the whole command: load 0-0.1, curving 0.1-0.9, writing 0.9-1.
  opt.progress = [&](const std::string& stage, double f) { progress(stage, 0.1 + 0.8 * f); };

  const double t0 = now_seconds();
  LoadedInput in = load_input(input, progress, read_options(a));
  print_input_warnings("curve", in);
  const double t1 = now_seconds();
  CurveResult res = curve_mesh(in.mesh, opt);
  const double t2 = now_seconds();
  progress("write", 0.9);
  write_msh_file(res.mesh, output, msh);
  const double t3 = now_seconds();
  progress("done", 1.0);

  if (a.has("stats")) {
    nlohmann::json s;
    s["generator"] = std::string("hocurve ") + HOCURVE_VERSION;
    s["input"] = input_json(input, in);
    s["curving"] = stats_json(res);
    s["output"] = {{"file", output},
                   {"format", msh.version == MshOptions::Version::V22 ? "msh22" : "msh41"},
                   {"binary", msh.binary},
                   {"order", res.mesh.order},
                   {"nodes", to_string(res.mesh.distribution)},
                   {"elements", res.mesh.num_faces()},
                   {"bytes", std::filesystem::file_size(output)}};
    s["seconds"] = {{"load", t1 - t0}, {"curve", t2 - t1}, {"write", t3 - t2}, {"total", t3 - t0}};
    write_json_file(a.get("stats"), s);
  }
  return 0;
}

}  // namespace hocurve::cli
