// The options `curve` and `volume` share: the curving knobs, the .msh format, the thread count.
#pragma once
#include "cli/args.hpp"
#include "engine/curving/solf.hpp"
#include "engine/highorder/write_msh.hpp"

#include <tbb/global_control.h>

#include <memory>
#include <vector>

namespace hocurve::cli {

/// --order, --format, --binary, --stats, --threads, the curving options, --progress, --help;
/// order_help describes --order (its range differs per command).
std::vector<OptionSpec> curve_option_specs(const std::string& order_help);

/// CurveOptions from the command line; --order in [1, max_order].
CurveOptions parse_curve_options(const Args& a, int max_order);

/// --format and --binary.
MshOptions parse_msh_options(const Args& a);

/// The TBB thread limit of --threads (null without it); keep it alive while working.
std::unique_ptr<tbb::global_control> thread_limit(const Args& a);

}  // namespace hocurve::cli
