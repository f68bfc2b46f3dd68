#include "cli/curve_options.hpp"

namespace hocurve::cli {

std::vector<OptionSpec> curve_option_specs(const std::string& order_help) {
  return {
      {"output", true, "output .msh file (required)", 'o'},
      {"order", true, order_help},
      {"format", true, "msh41 (default) | msh22"},
      {"binary", false, "binary .msh (little-endian, as Gmsh writes it)"},
      {"stats", true, "write every stage's figures and timings as JSON to this file"},
      {"threads", true, "worker threads (default: all cores)"},
      {"feature-angle", true, "dihedral angle in degrees above which an edge is sharp (default 35)"},
      {"tangent-junctions", true, "on (default: smooth borders where the curvature jumps, as a fillet's, are feature curves) | off"},
      {"exact-quadrics", true, "on (default: where vertices lie on a plane, sphere, cylinder, cone, ellipsoid or torus to rounding, fit it, however coarse) | off"},
      {"long-edge-ratio", true, "edges longer than this x the median edge at an end take PN triangles (default 2; 0: off)"},
      {"weld-tolerance", true, "merge vertices closer than this x the bounding-box diagonal (default 1e-9; 0: only exactly equal ones)"},
      {"support", true, "auto (default: when the triangulation is non-uniform) | on | off"},
      {"seed", true, "seed of the random support samples (default 1)"},
      {"untangle", true, "on (default: folded elements first have their nodes off feature curves moved along the surface) | off (only pulled toward straight)"},
      {"min-jacobian", true, "also pull valid elements whose min J/J_straight is at or below Q toward straight (default 0.01; 0: only invalid ones; e.g. 0.1)"},
      {"progress", false, "print progress as JSON lines on stdout"},
      {"help", false, "show this help", 'h'},
  };
}

CurveOptions parse_curve_options(const Args& a, int max_order) {
  CurveOptions opt;
  opt.order = static_cast<int>(a.get_int("order", std::min(4, max_order), 1, max_order));
  opt.features.angle_deg = a.get_double("feature-angle", opt.features.angle_deg, 0.0, 180.0);
  opt.features.tangent_junctions = a.get_choice("tangent-junctions", "on", {"on", "off"}) == "on";
  opt.features.exact_quadrics = opt.fit.exact_quadrics = a.get_choice("exact-quadrics", "on", {"on", "off"}) == "on";
  opt.long_edges.ratio = a.get_double("long-edge-ratio", opt.long_edges.ratio, 0.0, 1e9);
  opt.untangle.enabled = a.get_choice("untangle", "on", {"on", "off"}) == "on";
  opt.validity.quality_floor = a.get_double("min-jacobian", opt.validity.quality_floor, 0.0, 0.9);
  const std::string support = a.get_choice("support", "auto", {"auto", "on", "off"});
  opt.use_support = support == "on"    ? Tristate::On
                    : support == "off" ? Tristate::Off
                                       : Tristate::Auto;
  opt.support.seed = static_cast<std::uint64_t>(a.get_int("seed", 1, 0, (1LL << 62)));
  return opt;
}

MshOptions parse_msh_options(const Args& a) {
  MshOptions msh;
  msh.version = a.get_choice("format", "msh41", {"msh41", "msh22"}) == "msh22" ? MshOptions::Version::V22
                                                                              : MshOptions::Version::V41;
  msh.binary = a.has("binary");
  return msh;
}

std::unique_ptr<tbb::global_control> thread_limit(const Args& a) {
  if (!a.has("threads")) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                               static_cast<size_t>(a.get_int("threads", 1, 1, 1024)));
}

}  // namespace hocurve::cli
