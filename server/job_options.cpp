#include "server/job_options.hpp"

#include "server/json_text.hpp"
#include "server/problem.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <set>
#include <vector>

namespace hocurve::server {
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
  static const std::vector<std::string> known = {"mode",          "order",     "nodes",         "format",
                                                 "binary",        "faces",     "ratio",         "max_deviation",
                                                 "tolerance",     "max_faces", "feature_angle", "long_edge_ratio",
                                                 "min_jacobian",  "redecimate", "tangent_junctions", "weld_tolerance",
                                                 "exact_quadrics"};
  const auto value = [&](const std::string& key) { return Value{raw[key], !text_keys || text_keys->count(key) > 0}; };
  Errors err;
  for (auto& [k, v] : raw.items())
    if (std::find(known.begin(), known.end(), k) == known.end()) {
      std::string list;
      for (const auto& name : known) list += (list.empty() ? "" : ", ") + name;
      err.add(k, "unknown option '" + k + "' (known: " + list + ")");
    }

  nlohmann::json out = nlohmann::json::object();
  std::string mode = "curve";
  // A string option among `allowed` (JSON: a string; text: as it is), or `fallback` when absent.
  const auto choice = [&](const char* key, std::initializer_list<const char*> allowed, const char* fallback) {
    if (!raw.contains(key)) return std::string(fallback);
    const Value x = value(key);
    const std::string got = x.v.is_string() ? x.v.get<std::string>() : "";
    std::string list;
    for (const char* a : allowed) list += std::string(list.empty() ? "" : " or ") + "'" + a + "'";
    if (!x.v.is_string() || std::find(allowed.begin(), allowed.end(), got) == allowed.end())
      err.add(key, std::string(key) + " must be " + list + ", got " + (x.v.is_string() ? "'" + got + "'" : shown(x)));
    return x.v.is_string() ? got : as_text(x.v);
  };
  mode = choice("mode", {"curve", "coarsen"}, "curve");
  out["mode"] = mode;

  long long order = kDefaultOrder;
  if (raw.contains("order")) {
    if (!parse_int(value("order"), order) || order < kMinOrder || order > kMaxOrder)
      err.add("order", "order must be an integer from " + std::to_string(kMinOrder) + " to " +
                           std::to_string(kMaxOrder) + ", got " + shown(value("order")));
  }
  out["order"] = order;
  // An optional number `key` that ok() accepts; `what` words the accepted values for the error.
  const auto number = [&](const char* key, bool (*ok)(double), const char* what) {
    if (!raw.contains(key)) return;
    double x = 0;
    if (!parse_double(value(key), x) || !ok(x)) err.add(key, std::string(key) + " must be " + what + ", got " + shown(value(key)));
    out[key] = x;
  };
  // An optional face count `key` (4 .. 1e8).
  const auto face_count = [&](const char* key) {
    if (!raw.contains(key)) return;
    long long n = 0;
    if (!parse_int(value(key), n) || n < 4 || n > 100000000)
      err.add(key, std::string(key) + " must be an integer from 4 to 1e8, got " + shown(value(key)));
    out[key] = n;
  };
  // Both modes: the feature threshold and the long-edge rule of the dense fits.
  number("feature_angle", [](double x) { return x >= 0 && x <= 180; }, "a number of degrees in [0, 180]");
  number("long_edge_ratio", [](double x) { return x >= 0 && x <= 1e9; }, "a number in [0, 1e9] (0: off)");
  number("min_jacobian", [](double x) { return x >= 0 && x <= 0.9; }, "a number in [0, 0.9] (0: off)");
  number("weld_tolerance", [](double x) { return x >= 0 && x <= 0.01; }, "a number in [0, 0.01] (0: exact only)");

  if (mode == "coarsen") {
    for (const char* k : {"nodes", "format", "binary", "tangent_junctions", "exact_quadrics"})
      if (raw.contains(k)) err.add(k, std::string("option '") + k + "' applies to mode=curve only");
    bool has_faces = raw.contains("faces"), has_ratio = raw.contains("ratio");
    if (has_faces == has_ratio) err.add(has_faces ? "ratio" : "faces", "mode=coarsen needs exactly one of faces or ratio");
    face_count("faces");
    number("ratio", [](double x) { return x > 0 && x <= 1; }, "a number in (0, 1]");
    number("max_deviation", [](double x) { return x >= 0 && x <= 1; }, "a number in [0, 1] (0: no limit)");
    number("tolerance", [](double x) { return x >= 0 && x <= 1; }, "a number in [0, 1] (0: no refinement)");
    if (raw.contains("redecimate")) {
      long long n = 0;
      if (!parse_int(value("redecimate"), n) || n < 0 || n > 100)
        err.add("redecimate", "redecimate must be an integer from 0 to 100, got " + shown(value("redecimate")));
      out["redecimate"] = n;
    }
    face_count("max_faces");
    if (raw.contains("max_faces") && !raw.contains("tolerance")) err.add("max_faces", "max_faces needs tolerance");
  } else {
    for (const char* k : {"faces", "ratio", "max_deviation", "redecimate", "tolerance", "max_faces"})
      if (raw.contains(k)) err.add(k, std::string("option '") + k + "' applies to mode=coarsen only");
    // Equispaced by default: Gmsh's Lagrange elements (and the readers that follow them) put node k
    // at the k-th equispaced point, so Lobatto nodes read as equispaced distort the surface
    // (measured on the unit sphere, h = 0.1, P4: 4.4e-8 equispaced, 4.8e-5 Lobatto).
    out["nodes"] = choice("nodes", {"equispaced", "lobatto"}, "equispaced");
    out["format"] = choice("format", {"msh41", "msh22"}, "msh41");
    // An optional boolean `key` (text: 0/1/true/false) read into `on`; false when absent.
    const auto flag = [&](const char* key, bool& on) {
      if (!raw.contains(key)) return false;
      const Value x = value(key);
      if (!parse_bool(x, on))
        err.add(key, std::string(key) + (x.text ? " must be 0, 1, true or false" : " must be true or false") + ", got " +
                         shown(x));
      return true;
    };
    bool binary = false, junctions = true, quadrics = true;
    flag("binary", binary);
    out["binary"] = binary;
    if (flag("tangent_junctions", junctions)) out["tangent_junctions"] = junctions;  // only when given: the CLI's default is on
    if (flag("exact_quadrics", quadrics)) out["exact_quadrics"] = quadrics;
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
  const auto number = [&](const char* key) {  // round-trips the double
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", o[key].get<double>());
    return std::string(buf);
  };
  std::vector<std::string> a = {program, o.value("mode", "curve"), input, "-o", output, "--order",
                                std::to_string(o.value("order", kDefaultOrder))};
  if (o.value("mode", "curve") == "coarsen") {
    if (o.contains("faces")) a.insert(a.end(), {"--faces", std::to_string(o["faces"].get<long long>())});
    if (o.contains("ratio")) a.insert(a.end(), {"--ratio", number("ratio")});
    if (o.contains("max_deviation")) a.insert(a.end(), {"--max-deviation", number("max_deviation")});
    if (o.contains("redecimate")) a.insert(a.end(), {"--redecimate", std::to_string(o["redecimate"].get<long long>())});
    if (o.contains("tolerance")) a.insert(a.end(), {"--tolerance", number("tolerance")});
    if (o.contains("max_faces")) a.insert(a.end(), {"--max-faces", std::to_string(o["max_faces"].get<long long>())});
  } else {
    a.insert(a.end(), {"--nodes", o.value("nodes", "equispaced"), "--format", o.value("format", "msh41")});
    if (o.value("binary", false)) a.push_back("--binary");
    if (o.contains("tangent_junctions"))
      a.insert(a.end(), {"--tangent-junctions", o["tangent_junctions"].get<bool>() ? "on" : "off"});
    if (o.contains("exact_quadrics"))
      a.insert(a.end(), {"--exact-quadrics", o["exact_quadrics"].get<bool>() ? "on" : "off"});
    a.insert(a.end(), {"--threads", std::to_string(threads)});
  }
  if (o.contains("feature_angle")) a.insert(a.end(), {"--feature-angle", number("feature_angle")});
  if (o.contains("long_edge_ratio")) a.insert(a.end(), {"--long-edge-ratio", number("long_edge_ratio")});
  if (o.contains("min_jacobian")) a.insert(a.end(), {"--min-jacobian", number("min_jacobian")});
  if (o.contains("weld_tolerance")) a.insert(a.end(), {"--weld-tolerance", number("weld_tolerance")});
  a.insert(a.end(), {"--stats", stats, "--progress"});
  return a;
}

}  // namespace hocurve::server
