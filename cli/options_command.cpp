// hocurve options: the option registry as JSON, for scripts/gen_options.py (the OpenAPI schema,
// api/schemas/JobOptions.json and docs/options.md are generated from it).
#include "cli/command_options.hpp"
#include "cli/commands.hpp"

#include "engine/core/error.hpp"

#include <nlohmann/json.hpp>

#include <iostream>

namespace hocurve::cli {
namespace {

const char* type_name(OptionType t) {
  switch (t) {
    case OptionType::Int: return "int";
    case OptionType::Number: return "number";
    case OptionType::Choice: return "choice";
    case OptionType::Switch: return "switch";
    case OptionType::Flag: return "flag";
    case OptionType::Path: return "path";
  }
  return "";
}

nlohmann::json scope_names(unsigned bits) {
  nlohmann::json names = nlohmann::json::array();
  for (auto [bit, name] : {std::pair{kCurve, "curve"}, {kCoarsen, "coarsen"}, {kInfo, "info"}})
    if (bits & bit) names.push_back(name);
  return names;
}

nlohmann::json option_json(const OptionDef& d) {
  nlohmann::json j = {{"key", d.key},
                      {"flag", "--" + flag_name(d.key)},
                      {"type", type_name(d.type)},
                      {"doc", d.doc},
                      {"commands", scope_names(d.commands)},
                      {"modes", scope_names(d.modes)}};
  if (d.type == OptionType::Int || d.type == OptionType::Number) {
    j["min"] = d.lo, j["max"] = d.hi, j["job_min"] = job_lo(d);
    if (d.lo_open) j["exclusive_min"] = true;
    j["range"] = range_text(d);
    if (d.modes) j["job_range"] = range_text(d, true);
  }
  if (!d.choices.empty()) j["choices"] = d.choices;
  if (const double* x = std::get_if<double>(&d.def)) j["default"] = *x;
  if (const bool* b = std::get_if<bool>(&d.def)) j["default"] = *b;
  if (const std::string* s = std::get_if<std::string>(&d.def)) j["default"] = *s;
  j["default_text"] = default_text(d);
  if (d.zero_means) j["zero_means"] = d.zero_means;
  if (d.needs) j["needs"] = d.needs;
  if (d.metavar) j["metavar"] = d.metavar;
  if (d.short_name) j["short"] = std::string("-") + d.short_name;
  if (d.job_filled) j["job_filled"] = true;
  return j;
}

}  // namespace

int run_options(int argc, char** argv) {
  const std::vector<OptionSpec> specs = {{"json", false, "print the registry as JSON (the default)"},
                                         {"help", false, "show this help", 'h'}};
  Args a = parse_args(argc, argv, 2, specs);
  if (a.has("help")) {
    std::cout << "usage: hocurve options [--json]\nPrints every option of the commands and of the daemon's jobs "
                 "(name, type, range, default, doc) as JSON.\n\noptions:\n"
              << options_help(specs);
    return 0;
  }
  if (!a.positional.empty()) throw UsageError("options takes no arguments (see --help)");
  nlohmann::json j = nlohmann::json::array();
  for (const OptionDef& d : option_registry()) j.push_back(option_json(d));
  std::cout << j.dump(1) << "\n";
  return 0;
}

}  // namespace hocurve::cli
