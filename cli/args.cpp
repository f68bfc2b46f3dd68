#include "cli/args.hpp"

#include "engine/core/error.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

namespace hocurve::cli {

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values.find(name);
  return it == values.end() ? fallback : it->second;
}

long long Args::get_int(const std::string& name, long long fallback, long long lo, long long hi) const {
  if (!has(name)) return fallback;
  const std::string& s = values.at(name);
  long long v = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size())
    throw UsageError("--" + name + " expects an integer, got '" + s + "'");
  if (v < lo || v > hi)
    throw UsageError("--" + name + " must be in " + std::to_string(lo) + ".." + std::to_string(hi) +
                     ", got " + s);
  return v;
}

double Args::get_double(const std::string& name, double fallback, double lo, double hi, bool lo_open) const {
  if (!has(name)) return fallback;
  const std::string& s = values.at(name);
  double v = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v))
    throw UsageError("--" + name + " expects a number, got '" + s + "'");
  if (v < lo || v > hi || (lo_open && v == lo)) {
    std::ostringstream os;
    os << "--" << name << " must be in " << (lo_open ? "(" : "[") << lo << ", " << hi << "], got " << s;
    throw UsageError(os.str());
  }
  return v;
}

std::string Args::get_choice(const std::string& name, const std::string& fallback,
                             const std::vector<std::string>& choices) const {
  std::string v = get(name, fallback);
  for (const auto& c : choices)
    if (c == v) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : "|") + c;
  throw UsageError("--" + name + " must be one of " + list + ", got '" + v + "'");
}

Args parse_args(int argc, char** argv, int first, const std::vector<OptionSpec>& specs) {
  Args a;
  auto find = [&](const std::string& arg) -> const OptionSpec* {
    for (const auto& s : specs)
      if (arg == "--" + s.name || (s.short_name && arg == std::string("-") + s.short_name)) return &s;
    return nullptr;
  };
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg.size() > 1 && arg[0] == '-' && !(arg.size() > 1 && std::isdigit(static_cast<unsigned char>(arg[1])))) {
      std::string inline_value;
      bool has_inline = false;
      if (auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
        inline_value = arg.substr(eq + 1), arg = arg.substr(0, eq), has_inline = true;
      }
      const OptionSpec* s = find(arg);
      if (!s) throw UsageError("unknown option '" + arg + "' (see --help)");
      if (!s->takes_value) {
        if (has_inline) throw UsageError("option " + arg + " takes no value");
        a.values[s->name] = "1";
      } else if (has_inline) {
        a.values[s->name] = inline_value;
      } else {
        if (i + 1 >= argc) throw UsageError("option " + arg + " needs a value");
        a.values[s->name] = argv[++i];
      }
    } else {
      a.positional.push_back(arg);
    }
  }
  return a;
}

std::string options_help(const std::vector<OptionSpec>& specs) {
  std::ostringstream os;
  for (const auto& s : specs) {
    std::string left = "  ";
    left += s.short_name ? std::string("-") + s.short_name + ", " : "    ";
    left += "--" + s.name + (s.takes_value ? " " + s.value_name : "");
    os << left << std::string(left.size() < 30 ? 30 - left.size() : 1, ' ') << s.help << "\n";
  }
  return os.str();
}

}  // namespace hocurve::cli
