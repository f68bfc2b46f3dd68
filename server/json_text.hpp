// JSON to text for everything the daemon writes or sends. Strings can carry bytes that are not
// UTF-8 (a mesh's own text echoed in an error message, a header value); nlohmann's default dump
// throws on them, and a throw while saving a job's state left the job "running" on disk.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace hocurve::server {

/// j as text (indent < 0: one line), invalid UTF-8 replaced by U+FFFD.
inline std::string json_text(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

/// True when s is valid UTF-8 (what a JSON string may hold).
inline bool is_utf8(const std::string& s) {
  try {
    (void)nlohmann::json(s).dump();
    return true;
  } catch (const nlohmann::json::type_error&) {
    return false;
  }
}

}  // namespace hocurve::server
