// RFC 9457 problem details: every error response of hocurved is one of these.
#pragma once
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace hocurve::server {

/// An error to answer with application/problem+json. `type` is a stable slug (e.g. "invalid-options");
/// it is rendered as the URI "https://hocurve.dev/problems/<type>".
struct ApiError : std::runtime_error {
  int status;
  std::string type;
  nlohmann::json extra;  ///< extension members (errors[], retry_after, ...)
  ApiError(int status_, std::string type_, const std::string& detail, nlohmann::json extra_ = nlohmann::json::object())
      : std::runtime_error(detail), status(status_), type(std::move(type_)), extra(std::move(extra_)) {}
};

/// The problem object for `status`/`type`/`detail` (title derived from the type).
nlohmann::json make_problem(int status, const std::string& type, const std::string& detail,
                            const nlohmann::json& extra = nlohmann::json::object());

/// Human title for a problem type slug.
std::string problem_title(const std::string& type);

inline constexpr const char* kProblemBase = "https://hocurve.dev/problems/";

}  // namespace hocurve::server
