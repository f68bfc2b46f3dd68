#include "cli/command_options.hpp"

#include "engine/core/error.hpp"

#include <cmath>

namespace hocurve::cli {
namespace {

std::string value_name(const OptionDef& d) {
  if (d.type == OptionType::Switch) return "on|off";
  if (d.type != OptionType::Choice) return d.metavar ? d.metavar : "VALUE";
  std::string s;
  for (const auto& c : d.choices) s += (s.empty() ? "" : "|") + c;
  return s;
}

// The doc line with its range, default, meaning of 0 and dependency in parentheses.
std::string help_line(const OptionDef& d) {
  std::vector<std::string> notes;
  if (const std::string range = range_text(d); !range.empty()) notes.push_back(range);
  if (const std::string def = default_text(d); !def.empty() && d.type != OptionType::Flag) notes.push_back("default " + def);
  if (d.zero_means) notes.push_back(std::string("0: ") + d.zero_means);
  if (d.needs) notes.push_back("needs --" + flag_name(d.needs));
  std::string s = d.doc;
  for (size_t i = 0; i < notes.size(); ++i) s += (i ? "; " : " (") + notes[i];
  return notes.empty() ? s : s + ")";
}

OptionValue given_value(const Args& a, const OptionDef& d) {
  const std::string flag = flag_name(d.key);
  OptionValue v;
  switch (d.type) {
    case OptionType::Int:
      v.integer = a.get_int(flag, 0, (long long)d.lo, (long long)d.hi);
      v.number = double(v.integer);
      break;
    case OptionType::Number: v.number = a.get_double(flag, 0, d.lo, d.hi, d.lo_open); break;
    case OptionType::Choice: v.text = a.get_choice(flag, "", d.choices); break;
    case OptionType::Switch: v.on = a.get_choice(flag, "", {"on", "off"}) == "on"; break;
    case OptionType::Flag: v.on = true; break;
    case OptionType::Path: v.text = a.get(flag); break;
  }
  return v;
}

OptionValue default_value(const OptionDef& d) {
  OptionValue v;
  if (const double* x = std::get_if<double>(&d.def)) v.number = *x, v.integer = std::llround(*x);
  if (const bool* b = std::get_if<bool>(&d.def)) v.on = *b;
  if (const std::string* s = std::get_if<std::string>(&d.def)) v.text = *s;
  return v;
}

}  // namespace

std::vector<OptionSpec> command_specs(unsigned command) {
  std::vector<OptionSpec> specs;
  for (const OptionDef& d : option_registry())
    if (d.commands & command)
      specs.push_back({flag_name(d.key), d.type != OptionType::Flag, help_line(d), d.short_name, value_name(d)});
  specs.push_back({"help", false, "show this help", 'h'});
  return specs;
}

Args parse_command_line(int argc, char** argv, unsigned command) {
  return parse_args(argc, argv, 2, command_specs(command));
}

void apply_options(const Args& a, unsigned command, OptionSettings& s) {
  for (const OptionDef& d : option_registry()) {
    if (!(d.commands & command) || !d.apply) continue;
    const bool given = a.has(flag_name(d.key));
    if (given && d.needs && !a.has(flag_name(d.needs)))
      throw UsageError("--" + flag_name(d.key) + " needs --" + flag_name(d.needs));
    if (given) d.apply(s, given_value(a, d));
    else if (!std::holds_alternative<std::monostate>(d.def)) d.apply(s, default_value(d));
  }
}

std::string command_help(const std::string& usage, unsigned command) {
  return usage + "\noptions:\n" + options_help(command_specs(command));
}

}  // namespace hocurve::cli
