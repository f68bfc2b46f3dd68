// The option registry: well-formed entries, the engine's defaults, and the command line read from it.
#include "cli/command_options.hpp"

#include "engine/core/error.hpp"

#include <doctest/doctest.h>

#include <set>

using namespace hocurve;
using namespace hocurve::cli;

namespace {

// Reads `args` (after "hocurve CMD") for `command` into fresh settings.
OptionSettings read(unsigned command, std::vector<std::string> args) {
  args.insert(args.begin(), {"hocurve", "cmd"});
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  OptionSettings s;
  apply_options(parse_command_line(int(argv.size()), argv.data(), command), command, s);
  return s;
}

std::string refusal(unsigned command, const std::vector<std::string>& args) {
  try {
    read(command, args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "accepted";
}

}  // namespace

TEST_CASE("registry: each option once, with a doc, a range holding its default and a setter") {
  std::set<std::string> keys;
  for (const OptionDef& d : option_registry()) {
    CAPTURE(d.key);
    CHECK(keys.insert(d.key).second);
    CHECK(std::string(d.key).find('-') == std::string::npos);
    CHECK(std::string(d.doc).size() > 10);
    CHECK((d.commands | d.modes) != 0);
    if (d.commands) CHECK(bool(d.apply));
    if (const double* x = std::get_if<double>(&d.def)) {
      CHECK(*x >= d.lo);
      CHECK(*x <= d.hi);
    }
    if (const std::string* s = std::get_if<std::string>(&d.def))
      CHECK(std::find(d.choices.begin(), d.choices.end(), *s) != d.choices.end());
    CHECK(job_lo(d) >= d.lo);
    if (d.needs) CHECK(option(d.needs).commands == d.commands);
  }
}

TEST_CASE("registry: every job option is a flag of the command its mode runs") {
  // The daemon passes job options to the worker as these flags (server/job_options.cpp).
  for (const OptionDef& d : option_registry()) {
    if (!d.modes || std::string(d.key) == "mode") continue;
    CAPTURE(d.key);
    CHECK((d.commands & d.modes) == d.modes);
  }
}

TEST_CASE("registry: the defaults are the engine's") {
  const OptionSettings s = read(kCurve, {});
  CHECK(s.curve.order == CurveOptions{}.order);
  CHECK(s.curve.features.angle_deg == FeatureOptions{}.angle_deg);
  CHECK(s.curve.long_edges.ratio == LongEdgeOptions{}.ratio);
  CHECK(s.curve.validity.quality_floor == ValidityOptions{}.quality_floor);
  CHECK(s.read.weld_tolerance == ReadOptions{}.weld_tolerance);
  CHECK(s.curve.support.seed == SupportOptions{}.seed);
  CHECK(s.curve.distribution == CurveOptions{}.distribution);
  CHECK(s.curve.use_support == CurveOptions{}.use_support);
  CHECK(s.msh.version == MshOptions{}.version);
  const OptionSettings c = read(kCoarsen, {"--faces", "100"});
  // One feature angle for both commands: the decimation's own default agrees with the curving's.
  CHECK(c.decimate.feature_angle_deg == DecimateOptions{}.feature_angle_deg);
  CHECK(c.decimate.max_deviation == DecimateOptions{}.max_deviation);
  CHECK(c.redecimate.rounds == RedecimateOptions{}.rounds);
  CHECK(c.lift.order == LiftOptions{}.order);
  CHECK(c.lift.long_edges.ratio == LiftOptions{}.long_edges.ratio);
  CHECK(c.refine.tolerance == 0);  // refinement only when asked for
  CHECK(c.decimate.target_faces == 100);
}

TEST_CASE("command line: values reach the engine's structs") {
  const OptionSettings s = read(kCurve, {"-o", "x.msh", "--order", "3", "--feature-angle", "40", "--tangent-junctions",
                                         "off", "--exact-quadrics=off", "--binary", "--format", "msh22", "--seed", "7",
                                         "--support", "on", "--min-jacobian", "0.1", "--threads", "2", "--progress"});
  CHECK(s.output == "x.msh");
  CHECK(s.curve.order == 3);
  CHECK(s.curve.features.angle_deg == 40);
  CHECK(!s.curve.features.tangent_junctions);
  CHECK(!s.curve.features.exact_quadrics);
  CHECK(!s.curve.fit.exact_quadrics);
  CHECK(s.msh.binary);
  CHECK(s.msh.version == MshOptions::Version::V22);
  CHECK(s.curve.support.seed == 7);
  CHECK(s.curve.use_support == Tristate::On);
  CHECK(s.curve.validity.quality_floor == 0.1);
  CHECK(s.threads == 2);
  CHECK(s.progress);
  const OptionSettings c = read(kCoarsen, {"--ratio", "0.05", "--tolerance", "0.005", "--max-faces", "330",
                                           "--nodes", "lobatto", "--feature-angle", "50"});
  CHECK(c.decimate.target_ratio == 0.05);
  CHECK(c.refine.tolerance == 0.005);
  CHECK(c.redecimate.tolerance == 0.005);
  CHECK(c.refine.max_faces == 330);
  CHECK(c.lift.distribution == NodeDistribution::Lobatto);
  CHECK(c.decimate.feature_angle_deg == 50);
  CHECK(read(kInfo, {"--feature-angle", "20", "--json"}).features.angle_deg == 20);
}

TEST_CASE("command line: refusals name the flag and its range") {
  CHECK(refusal(kCurve, {"--feature-angle", "181"}) == "--feature-angle must be in [0, 180], got 181");
  CHECK(refusal(kCurve, {"--order", "7"}) == "--order must be in 1..6, got 7");
  CHECK(refusal(kCoarsen, {"--ratio", "0"}) == "--ratio must be in (0, 1], got 0");
  CHECK(refusal(kCoarsen, {"--ratio", "1"}) == "accepted");
  CHECK(refusal(kCoarsen, {"--faces", "10", "--max-faces", "100"}) == "--max-faces needs --tolerance");
  CHECK(refusal(kCurve, {"--tangent-junctions", "yes"}) == "--tangent-junctions must be one of on|off, got 'yes'");
  CHECK(refusal(kCurve, {"--faces", "10"}) == "unknown option '--faces' (see --help)");
  CHECK(refusal(kInfo, {"--order", "3"}) == "unknown option '--order' (see --help)");
}

TEST_CASE("help lists every option of the command with its default") {
  const std::string help = command_help("usage: hocurve curve\n", kCurve);
  for (const OptionDef& d : option_registry())
    CHECK((help.find("--" + flag_name(d.key) + " ") != std::string::npos) == bool(d.commands & kCurve));
  CHECK(help.find("--feature-angle DEG") != std::string::npos);
  CHECK(help.find("default 35") != std::string::npos);
  CHECK(help.find("-h, --help") != std::string::npos);
}

TEST_CASE("numbers are shown short") {
  CHECK(format_number(1e8) == "1e8");
  CHECK(format_number(1e-9) == "1e-9");
  CHECK(format_number(0.015) == "0.015");
  CHECK(format_number(180) == "180");
}
