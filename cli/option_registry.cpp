#include "cli/option_registry.hpp"

#include "cli/option_settings.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace hocurve::cli {
namespace {

using T = OptionType;
constexpr unsigned kModes = kCurve | kCoarsen;
constexpr unsigned kAll = kCurve | kCoarsen | kInfo;

// Choice defaults named from the engine's enums, so that the structs stay the one source.
std::string nodes_name(NodeDistribution d) { return d == NodeDistribution::Lobatto ? "lobatto" : "equispaced"; }
std::string format_name(MshOptions::Version v) { return v == MshOptions::Version::V22 ? "msh22" : "msh41"; }
std::string method_name(CurveOptions::Method m) { return m == CurveOptions::Method::Linear ? "linear" : "solf"; }
std::string tristate_name(Tristate t) { return t == Tristate::On ? "on" : t == Tristate::Off ? "off" : "auto"; }

std::vector<OptionDef> make_registry() {
  const CurveOptions curve;
  return {
      {.key = "mode", .type = T::Choice,
       .doc = "curve: curve the input mesh itself; coarsen: decimate it to faces or ratio coarse triangles, then "
              "curve those onto the input (hocurve curve | hocurve coarsen)",
       .modes = kModes, .choices = {"curve", "coarsen"}, .def = std::string("curve"), .job_filled = true},
      {.key = "output", .type = T::Path, .doc = "output .msh file (required)", .commands = kCurve | kCoarsen,
       .metavar = "OUTPUT.msh", .short_name = 'o',
       .apply = [](OptionSettings& s, const OptionValue& v) { s.output = v.text; }},
      // The daemon runs no order 1: that is the input (curve) or the straight decimated triangles.
      {.key = "order", .type = T::Int, .doc = "element order", .commands = kCurve | kCoarsen,
       .modes = kModes, .lo = 1, .hi = 6, .job_lo = 2, .def = double(curve.order), .metavar = "P", .job_filled = true,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.curve.order = s.lift.order = int(v.integer); }},
      {.key = "method", .type = T::Choice, .doc = "solf: nodes on the fitted surface; linear: on the flat facets",
       .commands = kCurve, .choices = {"solf", "linear"}, .def = method_name(curve.method),
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.method = v.text == "linear" ? CurveOptions::Method::Linear : CurveOptions::Method::Solf;
       }},
      // Equispaced by default: Gmsh's Lagrange elements (and the readers that follow them) put node k
      // at the k-th equispaced point, so Lobatto nodes read as equispaced distort the surface
      // (measured on the unit sphere, h = 0.1, P4: 4.4e-8 equispaced, 4.8e-5 Lobatto).
      {.key = "nodes", .type = T::Choice,
       .doc = "equispaced: where Gmsh's Lagrange elements (and most readers) put the nodes; lobatto only for "
              "readers that expect Gauss-Lobatto nodes",
       .commands = kCurve | kCoarsen, .modes = kCurve, .choices = {"equispaced", "lobatto"},
       .def = nodes_name(curve.distribution), .job_filled = true,
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.distribution = s.lift.distribution =
             v.text == "lobatto" ? NodeDistribution::Lobatto : NodeDistribution::Equispaced;
       }},
      {.key = "format", .type = T::Choice, .doc = "Gmsh MSH version of the result", .commands = kCurve | kCoarsen,
       .modes = kCurve, .choices = {"msh41", "msh22"}, .def = format_name(MshOptions{}.version), .job_filled = true,
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.msh.version = v.text == "msh22" ? MshOptions::Version::V22 : MshOptions::Version::V41;
       }},
      {.key = "binary", .type = T::Flag, .doc = "binary .msh (little-endian, as Gmsh writes it) instead of text",
       .commands = kCurve | kCoarsen, .modes = kCurve, .def = MshOptions{}.binary, .job_filled = true,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.msh.binary = v.on; }},
      {.key = "tangent_junctions", .type = T::Switch,
       .doc = "smooth borders where the curvature jumps (a fillet meeting a plane) are feature curves",
       .commands = kCurve, .modes = kCurve, .def = curve.features.tangent_junctions,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.curve.features.tangent_junctions = v.on; }},
      {.key = "exact_quadrics", .type = T::Switch,
       .doc = "where vertices lie on a plane, sphere, cylinder, cone, ellipsoid or torus to rounding (a CAD "
              "mesher's), fit it, however coarse the mesh",
       .commands = kCurve, .modes = kCurve, .def = curve.features.exact_quadrics,
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.features.exact_quadrics = s.curve.fit.exact_quadrics = v.on;
       }},
      {.key = "support", .type = T::Choice,
       .doc = "random support samples of the fits (auto: when the triangulation is non-uniform)", .commands = kCurve,
       .choices = {"auto", "on", "off"}, .def = tristate_name(curve.use_support),
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.use_support = v.text == "on" ? Tristate::On : v.text == "off" ? Tristate::Off : Tristate::Auto;
       }},
      {.key = "seed", .type = T::Int, .doc = "seed of the random support samples", .commands = kCurve, .lo = 0,
       .hi = std::ldexp(1.0, 62), .def = double(curve.support.seed), .metavar = "N",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.curve.support.seed = std::uint64_t(v.integer); }},
      {.key = "untangle", .type = T::Switch,
       .doc = "folded elements first have their nodes off feature curves moved along the surface (off: only "
              "pulled toward straight)",
       .commands = kCurve, .def = curve.untangle.enabled,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.curve.untangle.enabled = v.on; }},
      {.key = "faces", .type = T::Int, .doc = "target number of coarse triangles; exactly one of faces or ratio",
       .commands = kCoarsen, .modes = kCoarsen, .lo = 4, .hi = 1e8, .metavar = "N",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.decimate.target_faces = int(v.integer); }},
      {.key = "ratio", .type = T::Number,
       .doc = "target fraction of the input's triangles; exactly one of faces or ratio", .commands = kCoarsen,
       .modes = kCoarsen, .lo = 0, .hi = 1, .lo_open = true, .metavar = "R",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.decimate.target_ratio = v.number; }},
      {.key = "max_deviation", .type = T::Number,
       .doc = "collapses that would move a dense vertex further than this x the bounding-box diagonal from the "
              "straight coarse faces are refused",
       .commands = kCoarsen, .modes = kCoarsen, .lo = 0, .hi = 1, .def = DecimateOptions{}.max_deviation,
       .zero_means = "no limit", .metavar = "F",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.decimate.max_deviation = v.number; }},
      {.key = "redecimate", .type = T::Int,
       .doc = "where a few elements stray far more than the rest, decimate again up to this many times with the "
              "quadrics under them weighted up, and keep the closest",
       .commands = kCoarsen, .modes = kCoarsen, .lo = 0, .hi = 100, .def = double(RedecimateOptions{}.rounds),
       .zero_means = "off", .metavar = "K",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.redecimate.rounds = int(v.integer); }},
      // Default 0, not RefineOptions' target: refinement is asked for, never implied.
      {.key = "tolerance", .type = T::Number,
       .doc = "while elements are further than this x the bounding-box diagonal from the input (both ways), the "
              "face count grows (decimated again) and then they split their longest edges, up to max_faces",
       .commands = kCoarsen, .modes = kCoarsen, .lo = 0, .hi = 1, .def = 0.0, .zero_means = "no refinement",
       .metavar = "F",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.refine.tolerance = s.redecimate.tolerance = v.number; }},
      {.key = "max_faces", .type = T::Int,
       .doc = "never more coarse triangles than this when growing and splitting; a decimation that could not get "
              "below it is kept as it is",
       .commands = kCoarsen, .modes = kCoarsen, .lo = 4, .hi = 1e8, .default_text = "the input's count",
       .needs = "tolerance", .metavar = "N",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.refine.max_faces = int(v.integer); }},
      {.key = "feature_angle", .type = T::Number,
       .doc = "an edge is a feature when its dihedral angle exceeds this, in degrees", .commands = kAll,
       .modes = kModes, .lo = 0, .hi = 180, .def = curve.features.angle_deg, .metavar = "DEG",
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.features.angle_deg = s.decimate.feature_angle_deg = s.features.angle_deg = v.number;
       }},
      {.key = "long_edge_ratio", .type = T::Number,
       .doc = "edges longer than this x the median edge at an end, whose end fits disagree, take PN triangles",
       .commands = kCurve | kCoarsen, .modes = kModes, .lo = 0, .hi = 1e9, .def = curve.long_edges.ratio,
       .zero_means = "off", .metavar = "R",
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.long_edges.ratio = s.lift.long_edges.ratio = v.number;
       }},
      {.key = "weld_tolerance", .type = T::Number,
       .doc = "vertices closer than this x the bounding-box diagonal are merged on reading", .commands = kAll,
       .modes = kModes, .lo = 0, .hi = 0.01, .def = ReadOptions{}.weld_tolerance,
       .zero_means = "only exactly equal ones", .metavar = "F",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.read.weld_tolerance = v.number; }},
      {.key = "min_jacobian", .type = T::Number,
       .doc = "valid elements whose certified min J / J_straight is at or below this also go toward straight "
              "until they clear it",
       .commands = kCurve | kCoarsen, .modes = kModes, .lo = 0, .hi = 0.9, .def = curve.validity.quality_floor,
       .zero_means = "only invalid ones", .metavar = "Q",
       .apply = [](OptionSettings& s, const OptionValue& v) {
         s.curve.validity.quality_floor = s.lift.validity.quality_floor = v.number;
       }},
      {.key = "stats", .type = T::Path, .doc = "write every stage's figures and timings as JSON to this file",
       .commands = kCurve | kCoarsen, .metavar = "STATS.json",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.stats = v.text; }},
      {.key = "threads", .type = T::Int, .doc = "worker threads; the output is the same for any count",
       .commands = kCurve | kCoarsen, .lo = 1, .hi = 1024, .default_text = "all cores", .metavar = "N",
       .apply = [](OptionSettings& s, const OptionValue& v) { s.threads = int(v.integer); }},
      {.key = "progress", .type = T::Flag, .doc = "print progress as JSON lines on stdout",
       .commands = kCurve | kCoarsen, .def = false,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.progress = v.on; }},
      {.key = "json", .type = T::Flag, .doc = "print JSON instead of text", .commands = kInfo, .def = false,
       .apply = [](OptionSettings& s, const OptionValue& v) { s.json = v.on; }},
  };
}

}  // namespace

const std::vector<OptionDef>& option_registry() {
  static const std::vector<OptionDef> registry = make_registry();
  return registry;
}

const OptionDef& option(const std::string& key) {
  for (const OptionDef& d : option_registry())
    if (key == d.key) return d;
  throw std::logic_error("no option '" + key + "' in the registry");
}

std::string flag_name(const std::string& key) {
  std::string f = key;
  for (char& c : f)
    if (c == '_') c = '-';
  return f;
}

std::string format_number(double x) {
  int exp2 = 0;
  if (x >= 0x1p32 && std::frexp(x, &exp2) == 0.5) return "2^" + std::to_string(exp2 - 1);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  std::string s = buf;
  // %g's exponent "1e+08" reads as 1e8.
  if (auto e = s.find('e'); e != std::string::npos) {
    std::string mant = s.substr(0, e), exp = s.substr(e + 1);
    const bool neg = exp[0] == '-';
    exp = exp.substr(exp[0] == '-' || exp[0] == '+' ? 1 : 0);
    exp.erase(0, std::min(exp.find_first_not_of('0'), exp.size() - 1));
    s = mant + "e" + (neg ? "-" : "") + exp;
  }
  return s;
}

std::string range_text(const OptionDef& d, bool job) {
  const std::string lo = format_number(job ? job_lo(d) : d.lo), hi = format_number(d.hi);
  if (d.type == OptionType::Int) return lo + ".." + hi;
  if (d.type == OptionType::Number) return std::string(d.lo_open ? "(" : "[") + lo + ", " + hi + "]";
  return "";
}

std::string default_text(const OptionDef& d) {
  if (d.default_text) return d.default_text;
  if (const double* x = std::get_if<double>(&d.def)) return format_number(*x);
  if (const bool* b = std::get_if<bool>(&d.def)) return *b ? "on" : "off";
  if (const std::string* s = std::get_if<std::string>(&d.def)) return *s;
  return "";
}

}  // namespace hocurve::cli
