// Job options: validation and normalisation (query parameters or JSON), and the worker command line.
#pragma once
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

namespace hocurve::server {

// The daemon's orders, from the option registry (cli/option_registry.cpp).
extern const int kMinOrder, kMaxOrder, kDefaultOrder;

/// Validates raw options against the option registry's job options and returns them normalised,
/// with the defaults of the options the registry marks job_filled: {mode, order, nodes, format,
/// binary} for curve, {mode, order} for coarsen, plus the keys given. The values of `text_keys` (the query string's) are text: integers and
/// numbers as decimal text, booleans exactly 0, 1, true or false (the API's enum); the other values
/// (the multipart `options` part) must have the schema's JSON type: {"order": "3"} or {"binary": 1}
/// is refused. Without text_keys (an object built in code) every string is read as text.
/// Throws ApiError(400, "invalid-options") listing every offending key in `errors[]`.
nlohmann::json normalise_options(const nlohmann::json& raw, const std::set<std::string>* text_keys = nullptr);

/// Query parameters to a raw options object, every value its text (repeated keys are an error).
nlohmann::json options_from_query(const std::multimap<std::string, std::string>& params);

/// argv of the worker for one job (program first).
std::vector<std::string> worker_argv(const std::string& program, const nlohmann::json& options,
                                     const std::string& input, const std::string& output,
                                     const std::string& stats, int threads);

}  // namespace hocurve::server
