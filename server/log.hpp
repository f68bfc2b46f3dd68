// JSON-lines logging: one JSON object per line on stdout, built with nlohmann-json so that
// quotes and invalid UTF-8 in user strings never break a record.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace hocurve::server {

/// Writes `fields` plus `ts` (RFC 3339 UTC, ms), `level` and `msg` as one line on stdout.
void log_json(const std::string& level, const std::string& msg, nlohmann::json fields = nlohmann::json::object());

inline void log_info(const std::string& msg, nlohmann::json fields = nlohmann::json::object()) {
  log_json("info", msg, std::move(fields));
}
inline void log_warn(const std::string& msg, nlohmann::json fields = nlohmann::json::object()) {
  log_json("warn", msg, std::move(fields));
}
inline void log_error(const std::string& msg, nlohmann::json fields = nlohmann::json::object()) {
  log_json("error", msg, std::move(fields));
}

/// Seconds since the epoch as an RFC 3339 UTC string with milliseconds ("" for 0).
std::string rfc3339(double unix_seconds);

/// Current time in seconds since the epoch.
double now_seconds();

}  // namespace hocurve::server
