#include "server/job_options.hpp"

#include "server/problem.hpp"

#include <cmath>
#include <algorithm>
#include <vector>

namespace hocurve::server {
namespace {

struct Errors {
  nlohmann::json list = nlohmann::json::array();
  void add(const std::string& key, const std::string& msg) {
    list.push_back({{"pointer", "/options/" + key}, {"message", msg}});
  }
};

std::string as_text(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

bool parse_int(const nlohmann::json& v, long long& out) {
  if (v.is_number_integer()) { out = v.get<long long>(); return true; }
  if (v.is_number_float()) {
    double d = v.get<double>();
    if (std::floor(d) != d || std::abs(d) > 1e15) return false;
    out = (long long)d;
    return true;
  }
  if (!v.is_string()) return false;
  const std::string s = v.get<std::string>();
  if (s.empty() || s.size() > 18) return false;
  size_t i = (s[0] == '-' || s[0] == '+') ? 1 : 0;
  if (i == s.size()) return false;
  for (size_t j = i; j < s.size(); ++j)
    if (s[j] < '0' || s[j] > '9') return false;
  out = std::stoll(s);
  return true;
}

bool parse_double(const nlohmann::json& v, double& out) {
  if (v.is_number()) { out = v.get<double>(); return std::isfinite(out); }
  if (!v.is_string()) return false;
  const std::string s = v.get<std::string>();
  try {
    size_t pos = 0;
    out = std::stod(s, &pos);
    return pos == s.size() && std::isfinite(out);
  } catch (...) {
    return false;
  }
}

bool parse_bool(const nlohmann::json& v, bool& out) {
  if (v.is_boolean()) { out = v.get<bool>(); return true; }
  if (v.is_number_integer() && (v == 0 || v == 1)) { out = v == 1; return true; }
  if (!v.is_string()) return false;
  const std::string s = v.get<std::string>();
  if (s == "1" || s == "true" || s == "yes" || s == "") { out = true; return true; }
  if (s == "0" || s == "false" || s == "no") { out = false; return true; }
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

nlohmann::json normalise_options(const nlohmann::json& raw) {
  if (!raw.is_object())
    throw ApiError(400, "invalid-options", "options must be a JSON object, got " + std::string(raw.type_name()));
  static const std::vector<std::string> known = {"mode",          "order",     "nodes",         "format",
                                                 "binary",        "faces",     "ratio",         "max_deviation",
                                                 "tolerance",     "max_faces", "feature_angle", "long_edge_ratio",
                                                 "min_jacobian",  "redecimate", "tangent_junctions", "weld_tolerance"};
  Errors err;
  for (auto& [k, v] : raw.items())
    if (std::find(known.begin(), known.end(), k) == known.end()) {
      std::string list;
      for (const auto& name : known) list += (list.empty() ? "" : ", ") + name;
      err.add(k, "unknown option '" + k + "' (known: " + list + ")");
    }

  nlohmann::json out = nlohmann::json::object();
  std::string mode = "curve";
  if (raw.contains("mode")) {
    mode = as_text(raw["mode"]);
    if (mode != "curve" && mode != "coarsen") err.add("mode", "mode must be 'curve' or 'coarsen', got '" + mode + "'");
  }
  out["mode"] = mode;

  long long order = kDefaultOrder;
  if (raw.contains("order")) {
    if (!parse_int(raw["order"], order) || order < kMinOrder || order > kMaxOrder)
      err.add("order", "order must be an integer from " + std::to_string(kMinOrder) + " to " +
                           std::to_string(kMaxOrder) + ", got " + as_text(raw["order"]));
  }
  out["order"] = order;
  // An optional number `key` that ok() accepts; `what` words the accepted values for the error.
  const auto number = [&](const char* key, bool (*ok)(double), const char* what) {
    if (!raw.contains(key)) return;
    double x = 0;
    if (!parse_double(raw[key], x) || !ok(x)) err.add(key, std::string(key) + " must be " + what + ", got " + as_text(raw[key]));
    out[key] = x;
  };
  // An optional face count `key` (4 .. 1e8).
  const auto face_count = [&](const char* key) {
    if (!raw.contains(key)) return;
    long long n = 0;
    if (!parse_int(raw[key], n) || n < 4 || n > 100000000)
      err.add(key, std::string(key) + " must be an integer from 4 to 1e8, got " + as_text(raw[key]));
    out[key] = n;
  };
  // Both modes: the feature threshold and the long-edge rule of the dense fits.
  number("feature_angle", [](double x) { return x >= 0 && x <= 180; }, "a number of degrees in [0, 180]");
  number("long_edge_ratio", [](double x) { return x >= 0 && x <= 1e9; }, "a number >= 0 (0: off)");
  number("min_jacobian", [](double x) { return x >= 0 && x <= 0.9; }, "a number in [0, 0.9] (0: off)");
  number("weld_tolerance", [](double x) { return x >= 0 && x <= 0.01; }, "a number in [0, 0.01] (0: exact only)");

  if (mode == "coarsen") {
    for (const char* k : {"nodes", "format", "binary", "tangent_junctions"})
      if (raw.contains(k)) err.add(k, std::string("option '") + k + "' applies to mode=curve only");
    bool has_faces = raw.contains("faces"), has_ratio = raw.contains("ratio");
    if (has_faces == has_ratio) err.add(has_faces ? "ratio" : "faces", "mode=coarsen needs exactly one of faces or ratio");
    face_count("faces");
    number("ratio", [](double x) { return x > 0 && x <= 1; }, "a number in (0, 1]");
    number("max_deviation", [](double x) { return x >= 0 && x <= 1; }, "a number in [0, 1] (0: no limit)");
    number("tolerance", [](double x) { return x >= 0 && x <= 1; }, "a number in [0, 1] (0: no refinement)");
    if (raw.contains("redecimate")) {
      long long n = 0;
      if (!parse_int(raw["redecimate"], n) || n < 0 || n > 100)
        err.add("redecimate", "redecimate must be an integer from 0 to 100, got " + as_text(raw["redecimate"]));
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
    std::string nodes = raw.contains("nodes") ? as_text(raw["nodes"]) : "equispaced";
    if (nodes != "equispaced" && nodes != "lobatto")
      err.add("nodes", "nodes must be 'equispaced' or 'lobatto', got '" + nodes + "'");
    out["nodes"] = nodes;
    std::string format = raw.contains("format") ? as_text(raw["format"]) : "msh41";
    if (format != "msh41" && format != "msh22")
      err.add("format", "format must be 'msh41' or 'msh22', got '" + format + "'");
    out["format"] = format;
    // An optional 0/1/true/false `key` read into value; false when absent.
    const auto flag = [&](const char* key, bool& value) {
      if (!raw.contains(key)) return false;
      if (!parse_bool(raw[key], value)) err.add(key, std::string(key) + " must be 0/1/true/false, got " + as_text(raw[key]));
      return true;
    };
    bool binary = false, junctions = true;
    flag("binary", binary);
    out["binary"] = binary;
    if (flag("tangent_junctions", junctions)) out["tangent_junctions"] = junctions;  // only when given: the CLI's default is on
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
