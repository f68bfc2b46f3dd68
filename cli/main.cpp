// hocurve: command-line front end of the engine. Exit codes: 0 done, 2 usage, 3 bad input,
// 4 internal error, 5 out of memory; errors are one line on stderr.
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/core/error.hpp"

#include <cstring>
#include <iostream>
#include <new>

namespace {
const char* kUsage =
    "usage: hocurve <command> [options]\n"
    "commands:\n"
    "  curve    INPUT -o OUTPUT.msh --order P   curve a linear surface mesh into order-P triangles\n"
    "  coarsen  INPUT -o OUTPUT.msh --order P (--faces N | --ratio R)\n"
    "                                           decimate and lift a coarse curved mesh onto the input\n"
    "  volume   INPUT -o OUTPUT.msh --order P   fill a closed surface with order-P curved tets\n"
    "  info     INPUT [--json]                  counts, bounding box, edge statistics, problems\n"
    "  options  [--json]                        every option (name, type, range, default) as JSON\n"
    "  hocurve <command> --help                 options of a command\n"
    "exit codes: 0 done, 2 usage error, 3 input refused, 4 internal error, 5 out of memory\n";
}

int main(int argc, char** argv) {
  using namespace hocurve;
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    (argc < 2 ? std::cerr : std::cout) << kUsage;
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version")) {
    std::cout << "hocurve " << HOCURVE_VERSION << "\n";
    return 0;
  }
  const std::string cmd = argv[1];
  return cli::run_guarded([&] {
    if (cmd == "curve") return cli::run_curve(argc, argv);
    if (cmd == "info") return cli::run_info(argc, argv);
    if (cmd == "coarsen") return cli::run_coarsen(argc, argv);
    if (cmd == "options") return cli::run_options(argc, argv);
    if (cmd == "volume") return cli::exec_sibling("hocurve-volume", argv);
    throw UsageError("unknown command '" + cmd + "' (commands: curve, coarsen, volume, info, options)");
  });
}
