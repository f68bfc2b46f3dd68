// hocurve curve: dense curving of a linear surface mesh into a high-order .msh.
#include "cli/args.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stats_json.hpp"
#include "engine/highorder/write_msh.hpp"

#include <tbb/global_control.h>

#include <filesystem>
#include <iostream>
#include <memory>

namespace hocurve::cli {

namespace {

const std::vector<OptionSpec> kCurveOptions = {
    {"output", true, "output .msh file (required)", 'o'},
    {"order", true, "element order 1..6 (default 4)"},
    {"method", true, "solf (default: fitted surface) | linear (nodes on the flat facets)"},
    {"nodes", true, "equispaced (default; what Gmsh's Lagrange elements assume) | lobatto"},
    {"format", true, "msh41 (default) | msh22"},
    {"binary", false, "binary .msh (little-endian, as Gmsh writes it)"},
    {"stats", true, "write every stage's figures and timings as JSON to this file"},
    {"threads", true, "worker threads (default: all cores)"},
    {"feature-angle", true, "dihedral angle in degrees above which an edge is sharp (default 35)"},
    {"tangent-junctions", true, "on (default: smooth borders where the curvature jumps, as a fillet's, are feature curves) | off"},
    {"exact-quadrics", true, "on (default: where vertices lie on a plane, sphere, cylinder, cone, ellipsoid or torus to rounding, fit it, however coarse) | off"},
    {"long-edge-ratio", true, "edges longer than this x the median edge at an end take PN triangles (default 2; 0: off)"},
    {"weld-tolerance", true, "merge vertices closer than this x the bounding-box diagonal (default 1e-9; 0: only exactly equal ones)"},
    {"support", true, "auto (default: when the triangulation is non-uniform) | on | off"},
    {"seed", true, "seed of the random support samples (default 1)"},
    {"untangle", true, "on (default: folded elements first have their nodes off feature curves moved along the surface) | off (only pulled toward straight)"},
    {"min-jacobian", true, "also pull valid elements whose min J/J_straight is at or below Q toward straight (default 0.01; 0: only invalid ones; e.g. 0.1)"},
    {"progress", false, "print progress as JSON lines on stdout"},
    {"help", false, "show this help", 'h'},
};

const char* kCurveUsage =
    "usage: hocurve curve INPUT -o OUTPUT.msh [--order P] [--nodes equispaced|lobatto]\n"
    "                     [--format msh41|msh22] [--binary] [--stats STATS.json] [--threads N]\n"
    "Curves a linear triangle surface mesh (STL, OBJ, PLY, OFF, MSH; optionally .gz) into\n"
    "order-P curved triangles on a surface reconstructed from local least-squares fits.\n";

}  // namespace

int run_curve(int argc, char** argv) {
  Args a = parse_args(argc, argv, 2, kCurveOptions);
  if (a.has("help")) {
    std::cout << kCurveUsage << "\noptions:\n" << options_help(kCurveOptions);
    return 0;
  }
  if (a.positional.size() != 1) throw UsageError("curve needs exactly one INPUT file (see --help)");
  if (!a.has("output")) throw UsageError("curve needs -o OUTPUT.msh");
  const std::string input = a.positional[0], output = a.get("output");
  check_output_path("-o", output);
  if (a.has("stats")) check_output_path("--stats", a.get("stats"));

  CurveOptions opt;
  opt.order = static_cast<int>(a.get_int("order", 4, 1, 6));
  opt.method = a.get_choice("method", "solf", {"solf", "linear"}) == "linear" ? CurveOptions::Method::Linear
                                                                             : CurveOptions::Method::Solf;
  opt.distribution = parse_node_distribution(a.get_choice("nodes", "equispaced", {"equispaced", "lobatto"}));
  opt.features.angle_deg = a.get_double("feature-angle", opt.features.angle_deg, 0.0, 180.0);
  opt.features.tangent_junctions = a.get_choice("tangent-junctions", "on", {"on", "off"}) == "on";
  opt.features.exact_quadrics = opt.fit.exact_quadrics = a.get_choice("exact-quadrics", "on", {"on", "off"}) == "on";
  opt.long_edges.ratio = a.get_double("long-edge-ratio", opt.long_edges.ratio, 0.0, 1e9);
  opt.untangle.enabled = a.get_choice("untangle", "on", {"on", "off"}) == "on";
  opt.validity.quality_floor = a.get_double("min-jacobian", opt.validity.quality_floor, 0.0, 0.9);
  const std::string support = a.get_choice("support", "auto", {"auto", "on", "off"});
  opt.use_support = support == "on"    ? Tristate::On
                    : support == "off" ? Tristate::Off
                                       : Tristate::Auto;
  opt.support.seed = static_cast<std::uint64_t>(a.get_int("seed", 1, 0, (1LL << 62)));
  MshOptions msh;
  msh.version = a.get_choice("format", "msh41", {"msh41", "msh22"}) == "msh22" ? MshOptions::Version::V22
                                                                              : MshOptions::Version::V41;
  msh.binary = a.has("binary");
  std::unique_ptr<tbb::global_control> threads;
  if (a.has("threads"))
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<size_t>(a.get_int("threads", 1, 1, 1024)));
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
