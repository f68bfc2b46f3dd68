// hocurve-volume: `hocurve volume`, a program of its own because it links Gmsh (cli/common.hpp,
// exec_sibling); `hocurve volume ...` runs it with the same arguments.
#include "cli/commands.hpp"
#include "cli/common.hpp"

int main(int argc, char** argv) {
  return hocurve::cli::run_guarded([&] { return hocurve::cli::run_volume(argc, argv); });
}
