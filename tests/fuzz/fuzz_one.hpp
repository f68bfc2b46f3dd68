// What every reader harness does with one input, shared with the regression replay
// (tests/io/test_fuzz_regressions.cpp): sniff, read and validate like the CLI and the daemon do.
// A refusal (InputError) is a correct answer; any other exception escapes and is a bug.
#pragma once
#include "engine/core/error.hpp"
#include "engine/io/read_mesh.hpp"
#include "engine/io/validate_mesh.hpp"

#include <string>
#include <string_view>

namespace hocurve_fuzz {

/// Returns true when the input was read and validated, false when it was refused.
inline bool read_one(std::string_view bytes, const std::string& name) {
  try {
    (void)hocurve::detect_format(bytes, name);
    hocurve::ReadResult r = hocurve::read_mesh_bytes(bytes, name);
    hocurve::ValidateOptions vo;
    vo.name = name;
    hocurve::validate_mesh(r.mesh, vo);
    return true;
  } catch (const hocurve::InputError&) {
    return false;
  }
}

}  // namespace hocurve_fuzz
