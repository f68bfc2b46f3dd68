// hocurve curve: dense curving of a linear surface mesh into a high-order .msh.
#include "cli/command_options.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/solf.hpp"
#include "engine/curving/stats_json.hpp"
#include "engine/highorder/write_msh.hpp"


#include <filesystem>
#include <iostream>
#include <memory>

namespace hocurve::cli {

namespace {

const char* kCurveUsage =
    "usage: hocurve curve INPUT -o OUTPUT.msh [options]\n"
    "Curves a linear triangle surface mesh (STL, OBJ, PLY, OFF, MSH; optionally .gz) into\n"
    "order-P curved triangles on a surface reconstructed from local least-squares fits.\n";

}  // namespace

int run_curve(int argc, char** argv) {
  Args a = parse_command_line(argc, argv, kCurve);
  if (a.has("help")) {
    std::cout << command_help(kCurveUsage, kCurve);
    return 0;
  }
  if (a.positional.size() != 1) throw UsageError("curve needs exactly one INPUT file (see --help)");
  if (!a.has("output")) throw UsageError("curve needs -o OUTPUT.msh");
  OptionSettings o;
  apply_options(a, kCurve, o);
  const std::string input = a.positional[0], output = o.output;
  check_output_path("-o", output);
  if (!o.stats.empty()) check_output_path("--stats", o.stats);

  CurveOptions& opt = o.curve;
  const MshOptions& msh = o.msh;
  const auto threads = thread_limit(o.threads);
  Progress progress{o.progress};
  // One 0..1 scale for the whole command: load 0-0.1, curving 0.1-0.9, writing 0.9-1.
  opt.progress = [&](const std::string& stage, double f) { progress(stage, 0.1 + 0.8 * f); };

  const double t0 = now_seconds();
  LoadedInput in = load_input(input, progress, o.read);
  print_input_warnings("curve", in);
  const double t1 = now_seconds();
  CurveResult res = curve_mesh(in.mesh, opt);
  const double t2 = now_seconds();
  progress("write", 0.9);
  write_msh_file(res.mesh, output, msh);
  const double t3 = now_seconds();
  progress("done", 1.0);

  if (!o.stats.empty()) {
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
    write_json_file(o.stats, s);
  }
  return 0;
}

}  // namespace hocurve::cli
