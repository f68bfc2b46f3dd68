#include "server/byte_range.hpp"

#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <optional>

namespace hocurve::server {
namespace {

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

/// A decimal number of at most 18 digits; nothing for anything else (empty included).
std::optional<std::uint64_t> number(const std::string& s) {
  if (s.empty() || s.size() > 18 || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return std::stoull(s);
}

}  // namespace

ByteRange parse_byte_range(const std::string& header, std::uint64_t size) {
  const std::string h = trim(header);
  const size_t eq = h.find('=');
  if (eq == std::string::npos) return {};
  std::string unit = trim(h.substr(0, eq));
  for (char& c : unit) c = (char)std::tolower((unsigned char)c);
  std::string spec = trim(h.substr(eq + 1));
  if (unit != "bytes" || spec.find(',') != std::string::npos) return {};
  const size_t dash = spec.find('-');
  if (dash == std::string::npos) return {};
  const std::string a = trim(spec.substr(0, dash)), b = trim(spec.substr(dash + 1));
  ByteRange r;
  if (a.empty()) {  // -suffix: the last `suffix` bytes
    const auto suffix = number(b);
    if (!suffix) return {};
    if (*suffix == 0 || size == 0) return {ByteRange::kUnsatisfiable};
    r.length = std::min(*suffix, size);
    r.first = size - r.length;
  } else {
    const auto first = number(a);
    const auto last = b.empty() ? std::optional<std::uint64_t>(UINT64_MAX) : number(b);  // first-: to the end
    if (!first || !last || *last < *first) return {};
    if (*first >= size) return {ByteRange::kUnsatisfiable};
    r.first = *first;
    r.length = std::min(*last, size - 1) - *first + 1;
  }
  r.kind = ByteRange::kPart;
  return r;
}

bool httplib_refuses_range(const std::string& value) {
  httplib::Ranges ranges;
  try {
    return !httplib::detail::parse_range_header(value, ranges);
  } catch (const std::exception&) {  // std::stoll on more digits than fit
    return true;
  }
}

std::string content_range(const ByteRange& range, std::uint64_t size) {
  return "bytes " + std::to_string(range.first) + "-" + std::to_string(range.first + range.length - 1) + "/" +
         std::to_string(size);
}

}  // namespace hocurve::server
