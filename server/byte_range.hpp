// The `Range` header of a result download (RFC 9110 section 14): one byte range, so that an
// interrupted download of a large .msh can resume (curl -C -, wget -c, download managers).
#pragma once
#include <cstdint>
#include <string>

namespace hocurve::server {

struct ByteRange {
  enum Kind {
    kWhole,          ///< no usable Range: send the whole representation (200)
    kPart,           ///< send bytes [first, first + length) (206 with Content-Range)
    kUnsatisfiable,  ///< a valid range outside the representation (416, Content-Range: bytes */size)
  };
  Kind kind = kWhole;
  std::uint64_t first = 0, length = 0;
};

/// Reads `header` (a Range value) against a representation of `size` bytes. Units other than
/// bytes, malformed values and lists of several ranges are ignored (kWhole), as RFC 9110 allows;
/// `first-last` (last clipped to the end), `first-` and `-suffix` are served.
ByteRange parse_byte_range(const std::string& header, std::uint64_t size);

/// True when cpp-httplib 0.11 would refuse a `Range` header of this value (after the colon and
/// its blanks): it parses Range while reading the request, before any handler runs, and answers
/// 416 on every route to values RFC 9110 says to ignore ("bytes=abc", "items=0-5", "bytes=5-2")
/// and to some valid ones ("BYTES=0-9").
bool httplib_refuses_range(const std::string& value);

/// The `Content-Range` value of a part: "bytes first-last/size".
std::string content_range(const ByteRange& range, std::uint64_t size);

}  // namespace hocurve::server
