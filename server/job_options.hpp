// Job options: validation and normalisation (query parameters or JSON), and the worker command line.
#pragma once
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace hocurve::server {

inline constexpr int kMinOrder = 2;
inline constexpr int kMaxOrder = 6;
inline constexpr int kDefaultOrder = 4;  ///< the CLI's default too

/// Validates raw options (every value may be a string, as from a query string, or a JSON scalar)
/// and returns them normalised with defaults filled:
/// {mode, order, nodes, format, binary} for curve, {mode, order, faces|ratio} for coarsen.
/// Throws ApiError(400, "invalid-options") listing every offending key in `errors[]`.
nlohmann::json normalise_options(const nlohmann::json& raw);

/// Query parameters to a raw options object (repeated keys are an error).
nlohmann::json options_from_query(const std::multimap<std::string, std::string>& params);

/// argv of the worker for one job (program first).
std::vector<std::string> worker_argv(const std::string& program, const nlohmann::json& options,
                                     const std::string& input, const std::string& output,
                                     const std::string& stats, int threads);

}  // namespace hocurve::server
