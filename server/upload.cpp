#include "server/upload.hpp"

#include "server/http_server.hpp"
#include "server/problem.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <unistd.h>

namespace hocurve::server {
namespace {

constexpr std::size_t kHeadBytes = 64 * 1024;
constexpr std::size_t kMaxOptionsPart = 64 * 1024;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// Media types accepted as a raw mesh body. Anything else (JSON, form-urlencoded, ...) is 415.
bool mesh_media_type(const std::string& content_type) {
  std::string t = lower(content_type.substr(0, content_type.find(';')));
  while (!t.empty() && t.back() == ' ') t.pop_back();
  static const char* ok[] = {"application/octet-stream", "model/stl", "model/x.stl-binary", "model/x.stl-ascii",
                             "model/obj", "model/ply", "model/off", "text/plain", "application/sla",
                             "application/vnd.ms-pki.stl", "application/x-gmsh", "application/gzip",
                             "application/x-gzip"};
  for (const char* m : ok)
    if (t == m) return true;
  return false;
}

/// An upload slower than this on average, once kSlowGrace has passed, is cut off: each one holds
/// an HTTP thread, and a few clients dripping bytes would otherwise stall every request (health
/// probes too). 16 KiB/s moves 100 MB in under two hours.
constexpr double kMinUploadRate = 16 * 1024, kSlowGrace = 15;

struct Sink {
  int fd = -1;
  std::uint64_t bytes = 0, cap = 0, hash = 1469598103934665603ULL;  // FNV-1a 64
  std::string head;
  bool too_large = false, io_error = false, too_slow = false;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  /// False (and too_slow set) when the body so far, `total` bytes, came in below kMinUploadRate.
  bool fast_enough(std::uint64_t total) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    too_slow = t > kSlowGrace && total < kMinUploadRate * t;
    return !too_slow;
  }
  bool write(const char* data, size_t n) {
    bytes += n;
    if (!fast_enough(bytes)) return false;
    if (bytes > cap) {
      too_large = true;
      return false;
    }
    for (size_t i = 0; i < n; ++i) hash = (hash ^ (unsigned char)data[i]) * 1099511628211ULL;
    if (head.size() < kHeadBytes) head.append(data, std::min(n, kHeadBytes - head.size()));
    size_t off = 0;
    while (off < n) {
      ssize_t w = ::write(fd, data + off, n - off);
      if (w <= 0) {
        io_error = true;
        return false;
      }
      off += (size_t)w;
    }
    return true;
  }
};

std::string hex64(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)v);
  return buf;
}

std::string mb(std::uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g MiB", bytes / 1048576.0);
  return buf;
}

}  // namespace

void remove_quietly(const std::string& path) {
  if (!path.empty()) ::unlink(path.c_str());
}

void discard_body(const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader,
                  std::uint64_t limit) {
  const std::string text = req.get_header_value("Content-Length");
  const bool numeric = !text.empty() && text.size() < 18 && text.find_first_not_of("0123456789") == std::string::npos;
  const bool chunked = req.get_header_value("Transfer-Encoding").find("chunked") != std::string::npos;
  if (!chunked && (!numeric || std::stoull(text) > limit)) {
    res.set_header("Connection", "close");
    return;
  }
  std::uint64_t seen = 0;
  res.set_header("Connection", "close");  // a body cut short by the limit leaves the stream unusable
  if (req.is_multipart_form_data())
    reader([](const httplib::MultipartFormData&) { return true; },
           [&](const char*, size_t n) { seen += n; return seen <= limit; });
  else
    reader([&](const char*, size_t n) { seen += n; return seen <= limit; });
}

Upload receive_upload(const httplib::Request& req, const httplib::ContentReader& reader, std::uint64_t cap,
                      const std::string& dir, bool* reading) {
  if (!req.has_header("Content-Length"))
    throw ApiError(411, "length-required", "uploads need a Content-Length header (chunked bodies are not accepted)");
  const std::string length_text = req.get_header_value("Content-Length");
  if (length_text.empty() || length_text.find_first_not_of("0123456789") != std::string::npos || length_text.size() > 18)
    throw ApiError(400, "invalid-request", "Content-Length '" + length_text + "' is not a number");
  const std::uint64_t declared = std::stoull(length_text);
  // Multipart framing adds a few hundred bytes around the mesh; allow for it.
  const std::uint64_t framing = req.is_multipart_form_data() ? kMaxOptionsPart + 4096 : 0;
  if (declared > cap + framing)
    throw ApiError(413, "payload-too-large",
                   "upload of " + std::to_string(declared) + " bytes exceeds the limit of " + std::to_string(cap) +
                       " bytes (" + mb(cap) + ")",
                   {{"limit_bytes", cap}});
  const std::string content_type = req.get_header_value("Content-Type");
  const bool multipart = req.is_multipart_form_data();
  if (!multipart && !mesh_media_type(content_type))
    throw ApiError(415, "unsupported-media-type",
                   "Content-Type '" + content_type +
                       "' is not accepted: send the mesh as the raw body with Content-Type: "
                       "application/octet-stream (curl --data-binary @mesh.stl -H 'Content-Type: "
                       "application/octet-stream') or as multipart/form-data with parts 'mesh' and 'options'");
  static std::atomic<unsigned long long> counter{0};
  Upload up;
  up.multipart = multipart;
  up.path = dir + "/upload-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  Sink sink;
  sink.cap = cap;
  sink.fd = ::open(up.path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (sink.fd < 0)
    throw ApiError(503, "storage-unavailable",
                   std::string("cannot create an upload file in the data directory: ") + std::strerror(errno));
  if (reading) *reading = true;
  bool ok = true;
  std::string bad_part;
  int mesh_parts = 0;
  try {
    if (multipart) {
      std::string current;
      ok = reader(
          [&](const httplib::MultipartFormData& part) {
            current = part.name;
            if (current == "mesh") {
              ++mesh_parts;
              up.filename = part.filename;
              return mesh_parts == 1;
            }
            if (current != "options") {
              bad_part = current;
              return false;
            }
            return true;
          },
          [&](const char* data, size_t n) {
            if (current == "mesh") return sink.write(data, n);
            if (!sink.fast_enough(sink.bytes + up.options_json.size() + n)) return false;
            if (up.options_json.size() + n > kMaxOptionsPart) {
              bad_part = "options (larger than 64 KiB)";
              return false;
            }
            up.options_json.append(data, n);
            return true;
          });
    } else {
      ok = reader([&](const char* data, size_t n) { return sink.write(data, n); });
    }
  } catch (...) {
    ok = false;
  }
  ::close(sink.fd);
  up.bytes = sink.bytes;
  up.head = std::move(sink.head);
  up.fingerprint = hex64(sink.hash);
  auto fail = [&](ApiError e) {
    remove_quietly(up.path);
    throw e;
  };
  if (sink.too_large)
    fail(ApiError(413, "payload-too-large",
                  "upload exceeds the limit of " + std::to_string(cap) + " bytes (" + mb(cap) + ")",
                  {{"limit_bytes", cap}}));
  if (sink.io_error) fail(ApiError(507, "quota-exceeded", "cannot store the upload (disk full?)"));
  if (sink.too_slow)
    fail(ApiError(408, "request-timeout", "the upload came in slower than " +
                                              std::to_string((int)(kMinUploadRate / 1024)) + " KiB/s"));
  if (!bad_part.empty())
    fail(ApiError(400, "invalid-request",
                  "unexpected multipart part '" + bad_part + "': only 'mesh' (the file) and 'options' (JSON) are accepted"));
  if (mesh_parts > 1) fail(ApiError(400, "invalid-request", "multipart body has more than one 'mesh' part"));
  if (!ok && request_read_timed_out())
    fail(ApiError(408, "request-timeout", "the upload stalled: nothing arrived for longer than the read timeout"));
  if (!ok) fail(ApiError(400, "invalid-request", "the request body could not be read (connection closed or malformed multipart)"));
  if (multipart && mesh_parts == 0)
    fail(ApiError(400, "invalid-request", "multipart body has no 'mesh' part (curl -F mesh=@file.stl)"));
  if (!multipart && up.bytes != declared)
    fail(ApiError(400, "invalid-request", "body has " + std::to_string(up.bytes) + " bytes but Content-Length says " +
                                             std::to_string(declared)));
  return up;
}

}  // namespace hocurve::server
