// Receiving a mesh upload: streamed to a temporary file through httplib's ContentReader, with the
// size checked against Content-Length before reading and again while reading.
#pragma once
#include <httplib.h>

#include <cstdint>
#include <string>

namespace hocurve::server {

struct Upload {
  std::string path;          ///< temporary file holding the mesh bytes
  std::uint64_t bytes = 0;
  std::string head;          ///< first 64 KiB, for format sniffing
  std::string filename;      ///< client file name (multipart), may be empty
  std::string options_json;  ///< the multipart `options` part, may be empty
  bool multipart = false;
  std::string fingerprint;   ///< hash of the mesh bytes (hex)
};

/// Reads the body of `req` into a new file under `dir`. Throws ApiError: 411 without Content-Length,
/// 413 above `cap` bytes, 415 for a media type that is not a mesh or multipart/form-data, 400 for
/// a malformed multipart body. The caller owns (and must delete) `path` afterwards.
/// `*reading` becomes true once the body is being read (after that it must not be read again).
Upload receive_upload(const httplib::Request& req, const httplib::ContentReader& reader, std::uint64_t cap,
                      const std::string& dir, bool* reading = nullptr);

/// Reads and drops a small unread body so the connection stays usable after an early error
/// (bodies above `limit` are not read; the connection is closed instead).
void discard_body(const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader,
                  std::uint64_t limit = 4u << 20);

/// Removes a file, ignoring errors.
void remove_quietly(const std::string& path);

}  // namespace hocurve::server
