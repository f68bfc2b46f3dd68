// The sub-commands of `hocurve`. Each returns the process exit code and throws
// UsageError (exit 2) or InputError (exit 3) on refusal.
#pragma once

namespace hocurve::cli {

int run_curve(int argc, char** argv);    ///< hocurve curve INPUT -o OUTPUT.msh --order P ...
int run_info(int argc, char** argv);     ///< hocurve info INPUT [--json]
int run_coarsen(int argc, char** argv);  ///< hocurve coarsen INPUT -o OUTPUT.msh --order P (--faces N | --ratio R)
int run_options(int argc, char** argv);  ///< hocurve options [--json]: the option registry
int run_volume(int argc, char** argv);   ///< hocurve volume INPUT -o OUTPUT.msh --order P [--size H] ...

}  // namespace hocurve::cli
