// The registry's options on the command line: each sub-command's option list, --help and
// range-checked reading into OptionSettings.
#pragma once
#include "cli/args.hpp"
#include "cli/option_registry.hpp"
#include "cli/option_settings.hpp"

#include <string>
#include <vector>

namespace hocurve::cli {

/// The options `command` (a Scope bit) takes, from the registry, plus -h/--help.
std::vector<OptionSpec> command_specs(unsigned command);

/// Parses argv[2..) of `command`; throws UsageError on unknown options or missing values.
Args parse_command_line(int argc, char** argv, unsigned command);

/// Applies every option of `command` to `s`: the given value, range-checked (UsageError naming the
/// flag), else the registry's default; options without a default are left alone when absent.
void apply_options(const Args& a, unsigned command, OptionSettings& s);

/// The --help text: `usage`, then the option list.
std::string command_help(const std::string& usage, unsigned command);

}  // namespace hocurve::cli
