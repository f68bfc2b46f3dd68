// Errors the engine reports: what was wrong, where, and why, in one line.
#pragma once
#include <stdexcept>
#include <string>

namespace hocurve {

/// The input cannot be used (malformed file, refused topology, bad option value).
/// Maps to CLI exit code 3 and HTTP 415/422. `where` names the file and line/facet.
struct InputError : std::runtime_error {
  std::string where;
  InputError(std::string where_, const std::string& why)
      : std::runtime_error(where_.empty() ? why : where_ + ": " + why), where(std::move(where_)) {}
};

/// A caller asked for something out of range (order 0, unknown option). CLI exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace hocurve
