#include "server/job_options.hpp"

#include "cli/option_registry.hpp"
#include "server/json_text.hpp"
#include "server/problem.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

namespace hocurve::server {

using cli::OptionDef;
using cli::OptionType;

const int kMinOrder = int(cli::job_lo(cli::option("order")));
const int kMaxOrder = int(cli::option("order").hi);
const int kDefaultOrder = int(std::get<double>(cli::option("order").def));

namespace {

struct Errors {
  nlohmann::json list = nlohmann::json::array();
  void add(const std::string& key, const std::string& msg) {
    std::string token;  // RFC 6901: '~' and '/' escaped
    for (char c : key) token += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    list.push_back({{"pointer", "/options/" + token}, {"message", msg}});
  }
};

// How a value is read. Query parameters are text ("3", "0.5", "true"); the multipart `options` part
// is JSON and must use JSON types (3, 0.5, true): "3" there is a string, refused where a number is
// expected. Without a list of the query's keys (objects built in code) strings are read as text.
struct Value {
  const nlohmann::json& v;
  bool text;  // a string is read as text
};

std::string as_text(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// The value as the error message shows it: text as it is, JSON as JSON ("3" with its quotes).
std::string shown(const Value& x) {
  if (x.text && x.v.is_string()) return x.v.get<std::string>();
  std::string s = json_text(x.v);
  if (x.v.is_string()) s += " (a JSON string: the options part takes JSON numbers and booleans, not strings)";
  return s;
}

bool parse_int(const Value& x, long long& out) {
  const nlohmann::json& v = x.v;
  if (v.is_number_integer()) { out = v.get<long long>(); return true; }
  if (v.is_number_float()) {  // 3.0 is an integer in JSON Schema
    double d = v.get<double>();
    if (std::floor(d) != d || std::abs(d) > 1e15) return false;
    out = (long long)d;
    return true;
  }
  if (!v.is_string() || !x.text) return false;
  const std::string s = v.get<std::string>();
  if (s.empty() || s.size() > 18) return false;
  size_t i = (s[0] == '-' || s[0] == '+') ? 1 : 0;
  if (i == s.size()) return false;
  for (size_t j = i; j < s.size(); ++j)
    if (s[j] < '0' || s[j] > '9') return false;
  out = std::stoll(s);
  return true;
}

bool parse_double(const Value& x, double& out) {
  const nlohmann::json& v = x.v;
  if (v.is_number()) { out = v.get<double>(); return std::isfinite(out); }
  if (!v.is_string() || !x.text) return false;
  const std::string s = v.get<std::string>();
  if (s.empty() || std::isspace((unsigned char)s[0])) return false;
  try {
    size_t pos = 0;
    out = std::stod(s, &pos);
    return pos == s.size() && std::isfinite(out);
  } catch (...) {
    return false;
  }
}

// JSON: true or false. Text: exactly the API's enum 0, 1, true, false.
bool parse_bool(const Value& x, bool& out) {
  const nlohmann::json& v = x.v;
  if (v.is_boolean()) { out = v.get<bool>(); return true; }
  if (!v.is_string() || !x.text) return false;
  const std::string s = v.get<std::string>();
  if (s == "1" || s == "true") { out = true; return true; }
  if (s == "0" || s == "false") { out = false; return true; }
  return false;
}

// The registry's job options, in its order.
const std::vector<const OptionDef*>& job_options() {
  static const std::vector<const OptionDef*> list = [] {
    std::vector<const OptionDef*> l;
    for (const OptionDef& d : cli::option_registry())
      if (d.modes) l.push_back(&d);
    return l;
  }();
  return list;
}

unsigned mode_bit(const std::string& mode) { return mode == "coarsen" ? cli::kCoarsen : cli::kCurve; }

std::string mode_names(unsigned modes) {
  std::string s;
  for (auto [bit, name] : {std::pair{cli::kCurve, "curve"}, {cli::kCoarsen, "coarsen"}})
    if (modes & bit) s += std::string(s.empty() ? "" : " or ") + "mode=" + name;
  return s;
}

// What an Int or Number accepts, as the error message words it.
std::string accepted(const OptionDef& d) {
  if (d.type == OptionType::Int)
    return "an integer from " + cli::format_number(cli::job_lo(d)) + " to " + cli::format_number(d.hi);
  const std::string s = "a number in " + cli::range_text(d, true);
  return d.zero_means ? s + " (0: " + d.zero_means + ")" : s;
}

// One given option, typed; an error is added when it is not acceptable.
nlohmann::json read_option(const OptionDef& d, const Value& x, Errors& err) {
  const std::string key = d.key;
  switch (d.type) {
    case OptionType::Int: {
      long long n = 0;
      if (!parse_int(x, n) || n < cli::job_lo(d) || n > d.hi) err.add(key, key + " must be " + accepted(d) + ", got " + shown(x));
      return n;
    }
    case OptionType::Number: {
      double v = 0;
      const bool in = parse_double(x, v) && v >= d.lo && v <= d.hi && !(d.lo_open && v == d.lo);
      if (!in) err.add(key, key + " must be " + accepted(d) + ", got " + shown(x));
      return v;
    }
    case OptionType::Choice: {
      const std::string got = x.v.is_string() ? x.v.get<std::string>() : "";
      if (!x.v.is_string() || std::find(d.choices.begin(), d.choices.end(), got) == d.choices.end()) {
        std::string list;
        for (const auto& c : d.choices) list += (list.empty() ? "'" : " or '") + c + "'";
        err.add(key, key + " must be " + list + ", got " + (x.v.is_string() ? "'" + got + "'" : shown(x)));
      }
      return x.v.is_string() ? got : as_text(x.v);
    }
    default: {  // Switch, Flag: a boolean
      bool on = false;
      if (!parse_bool(x, on))
        err.add(key, key + (x.text ? " must be 0, 1, true or false" : " must be true or false") + ", got " + shown(x));
      return on;
    }
  }
}

nlohmann::json default_json(const OptionDef& d) {
  if (const double* x = std::get_if<double>(&d.def)) {
    if (d.type == OptionType::Int) return (long long)std::llround(*x);
    return *x;
  }
  if (const bool* b = std::get_if<bool>(&d.def)) return *b;
  return std::get<std::string>(d.def);
}

// The worker's arguments for one normalised option (none for a Flag that is off).
std::vector<std::string> worker_args(const OptionDef& d, const nlohmann::json& v) {
  const std::string flag = "--" + cli::flag_name(d.key);
  switch (d.type) {
    case OptionType::Int: return {flag, std::to_string(v.get<long long>())};
    case OptionType::Number: {  // round-trips the double
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", v.get<double>());
      return {flag, buf};
    }
    case OptionType::Switch: return {flag, v.get<bool>() ? "on" : "off"};
    case OptionType::Flag: return v.get<bool>() ? std::vector<std::string>{flag} : std::vector<std::string>{};
    default: return {flag, v.get<std::string>()};
  }
}

}  // namespace

nlohmann::json options_from_query(const std::multimap<std::string, std::string>& params) {
  nlohmann::json raw = nlohmann::json::object();
  for (auto& [k, v] : params) {
    if (raw.contains(k))
      throw ApiError(400, "invalid-options", "query parameter '" + k + "' given more than once",
                     {{"errors", {{{"pointer", "/options/" + k}, {"message", "repeated"}}}}});
    raw[k] = v;
  }
  return raw;
}

nlohmann::json normalise_options(const nlohmann::json& raw, const std::set<std::string>* text_keys) {
  if (!raw.is_object())
    throw ApiError(400, "invalid-options", "options must be a JSON object, got " + std::string(raw.type_name()));
  const auto value = [&](const std::string& key) { return Value{raw[key], !text_keys || text_keys->count(key) > 0}; };
  const auto known = [](const std::string& key) {
    for (const OptionDef* d : job_options())
      if (key == d->key) return true;
    return false;
  };
  Errors err;
  for (auto& [k, v] : raw.items())
    if (!known(k)) {
      std::string list;
      for (const OptionDef* d : job_options()) list += (list.empty() ? "" : ", ") + std::string(d->key);
      err.add(k, "unknown option '" + k + "' (known: " + list + ")");
    }

  nlohmann::json out = nlohmann::json::object();
  const OptionDef& mode_def = cli::option("mode");
  out["mode"] = raw.contains("mode") ? read_option(mode_def, value("mode"), err) : default_json(mode_def);
  const std::string mode = out["mode"].get<std::string>();
  for (const OptionDef* d : job_options()) {
    const std::string key = d->key;
    if (key == "mode") continue;
    if (!(d->modes & mode_bit(mode))) {
      if (raw.contains(key)) err.add(key, "option '" + key + "' applies to " + mode_names(d->modes) + " only");
      continue;
    }
    if (raw.contains(key)) out[key] = read_option(*d, value(key), err);
    else if (d->job_filled) out[key] = default_json(*d);
    if (d->needs && raw.contains(key) && !raw.contains(d->needs)) err.add(key, key + " needs " + d->needs);
  }
  if (mode == "coarsen") {
    const bool has_faces = raw.contains("faces"), has_ratio = raw.contains("ratio");
    if (has_faces == has_ratio) err.add(has_faces ? "ratio" : "faces", "mode=coarsen needs exactly one of faces or ratio");
  }
  if (!err.list.empty()) {
    std::string detail;
    for (auto& e : err.list) detail += (detail.empty() ? "" : "; ") + e["message"].get<std::string>();
    throw ApiError(400, "invalid-options", detail, {{"errors", err.list}});
  }
  return out;
}

std::vector<std::string> worker_argv(const std::string& program, const nlohmann::json& o, const std::string& input,
                                     const std::string& output, const std::string& stats, int threads) {
  const std::string mode = o.value("mode", "curve");
  std::vector<std::string> a = {program, mode, input, "-o", output};
  for (const OptionDef* d : job_options()) {
    if (std::string(d->key) == "mode" || !(d->modes & mode_bit(mode))) continue;
    if (!o.contains(d->key) && !d->job_filled) continue;
    const std::vector<std::string> args = worker_args(*d, o.contains(d->key) ? o[d->key] : default_json(*d));
    a.insert(a.end(), args.begin(), args.end());
  }
  if (mode == "curve") a.insert(a.end(), {"--threads", std::to_string(threads)});
  a.insert(a.end(), {"--stats", stats, "--progress"});
  return a;
}
}  // namespace hocurve::server
