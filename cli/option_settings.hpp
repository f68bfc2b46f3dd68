// What the options are applied to: the engine's option structs of every command, plus the CLI's own
// settings. Each command reads the parts it runs.
#pragma once
#include "engine/coarse/decimate.hpp"
#include "engine/coarse/lift.hpp"
#include "engine/coarse/redecimate.hpp"
#include "engine/coarse/refine.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/solf.hpp"
#include "engine/highorder/write_msh.hpp"
#include "engine/io/read_mesh.hpp"

#include <string>

namespace hocurve::cli {

struct OptionSettings {
  CurveOptions curve;            ///< hocurve curve
  DecimateOptions decimate;      ///< hocurve coarsen
  LiftOptions lift;
  RefineOptions refine;
  RedecimateOptions redecimate;
  FeatureOptions features;       ///< hocurve info
  ReadOptions read;              ///< every command
  MshOptions msh;
  std::string output, stats;
  int threads = 0;               ///< 0: all cores
  bool progress = false, json = false;
};

}  // namespace hocurve::cli
