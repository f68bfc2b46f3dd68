// The curving statistics as JSON (CLI --stats, daemon job results).
#pragma once
#include "engine/curving/solf.hpp"

#include <nlohmann/json.hpp>

namespace hocurve {

/// Every stage's figures and seconds, the fit-degree histogram, downgraded fits, repaired
/// elements, min scaled Jacobian and the deviation from the input.
nlohmann::json stats_json(const CurveResult& r);

}  // namespace hocurve
