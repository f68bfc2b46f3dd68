// A small command-line parser: positional arguments plus declared --options.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace hocurve::cli {

/// One declared option: `--name VALUE` when takes_value, else a `--name` flag.
struct OptionSpec {
  std::string name;
  bool takes_value = true;
  std::string help;
  char short_name = 0;  ///< e.g. 'o' for -o
  std::string value_name = "VALUE";  ///< the value's placeholder in --help
};

/// Parsed command line of one sub-command.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> values;  ///< option name -> value ("1" for flags)

  bool has(const std::string& name) const { return values.count(name) > 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const;
  /// Integer option in [lo, hi]; throws UsageError naming the option otherwise.
  long long get_int(const std::string& name, long long fallback, long long lo, long long hi) const;
  /// Floating-point option in [lo, hi], or (lo, hi] when lo_open.
  double get_double(const std::string& name, double fallback, double lo, double hi, bool lo_open = false) const;
  /// Value that must be one of `choices`.
  std::string get_choice(const std::string& name, const std::string& fallback,
                         const std::vector<std::string>& choices) const;
};

/// Parses argv[first..argc); throws UsageError on unknown options or missing values.
Args parse_args(int argc, char** argv, int first, const std::vector<OptionSpec>& specs);

/// Formats the option list for --help.
std::string options_help(const std::vector<OptionSpec>& specs);

}  // namespace hocurve::cli
