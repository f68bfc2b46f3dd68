// The user-facing options, each declared once (after Gmsh's options table): the CLI's flags, help
// and parsing, the daemon's validation and worker arguments, the OpenAPI schema and docs/options.md
// all come from option_registry(). Regenerate the documents with `make options`.
#pragma once

#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace hocurve::cli {

enum class OptionType {
  Int,     ///< --name N; a JSON integer
  Number,  ///< --name X; a JSON number
  Choice,  ///< --name one of `choices`; a JSON string
  Switch,  ///< --name on|off; a JSON boolean
  Flag,    ///< --name without a value; a JSON boolean
  Path,    ///< --name FILE; CLI only
};

/// Where an option applies: bits of OptionDef::commands (CLI sub-commands) and ::modes (job modes).
enum Scope : unsigned { kCurve = 1, kCoarsen = 2, kInfo = 4 };

struct OptionSettings;  // cli/option_settings.hpp: what the options are applied to

/// A typed option value: `integer` (and `number`) for Int, `number` for Number, `on` for Switch
/// and Flag, `text` otherwise.
struct OptionValue {
  long long integer = 0;
  double number = 0;
  bool on = false;
  std::string text;
};

/// A default: none, a number, a boolean or a choice.
using OptionDefault = std::variant<std::monostate, double, bool, std::string>;

struct OptionDef {
  const char* key = nullptr;   ///< job key, e.g. "feature_angle"; the CLI flag is --feature-angle
  OptionType type = OptionType::Int;
  const char* doc = nullptr;   ///< one line: --help, the schema's description, docs/options.md
  unsigned commands = 0;       ///< CLI sub-commands taking it (0: a job option only)
  unsigned modes = 0;          ///< job modes taking it (0: not a job option)
  double lo = 0, hi = 0;       ///< Int and Number: the accepted range
  bool lo_open = false;        ///< (lo, hi] instead of [lo, hi]
  std::optional<double> job_lo{};  ///< the daemon's lower bound where narrower than the CLI's
  std::vector<std::string> choices{};  ///< Choice
  OptionDefault def{};         ///< from the engine's option structs where they have one
  const char* default_text = nullptr;  ///< the default in words where it is not a value
  const char* zero_means = nullptr;    ///< what 0 does, e.g. "off"
  const char* needs = nullptr;         ///< key of another option this one needs
  const char* metavar = nullptr;       ///< value placeholder in usage lines, e.g. "DEG"
  char short_name = 0;                 ///< e.g. 'o' for -o
  bool job_filled = false;     ///< the daemon states it in every job of its modes, default or not
  void (*apply)(OptionSettings&, const OptionValue&) = nullptr;
};

/// Every option, in the order of --help, the schema and the docs.
const std::vector<OptionDef>& option_registry();

/// The entry of `key`; throws std::logic_error for an unknown key (a programming error).
const OptionDef& option(const std::string& key);

/// The CLI flag of a key: feature_angle -> feature-angle.
std::string flag_name(const std::string& key);

/// A number as the docs and messages show it: 1e8 rather than 100000000, 2^62, 0.015 as it is.
std::string format_number(double x);

/// The accepted range as text: "1..6" (Int), "[0, 180]" or "(0, 1]" (Number); empty otherwise.
/// With `job`, the daemon's.
std::string range_text(const OptionDef& d, bool job = false);

/// The default as text ("35", "on", "equispaced", "all cores"), empty when there is none.
std::string default_text(const OptionDef& d);

/// The lower bound the daemon accepts.
inline double job_lo(const OptionDef& d) { return d.job_lo.value_or(d.lo); }

}  // namespace hocurve::cli
