// HTTP routes of hocurved. Handlers only validate, store, enqueue or read state: geometry runs in
// worker processes (job_runner.cpp), never on an HTTP thread.
#include "server/app.hpp"
#include "server/byte_range.hpp"
#include "server/format_sniff.hpp"
#include "server/http_server.hpp"
#include "server/job_options.hpp"
#include "server/json_text.hpp"
#include "server/log.hpp"
#include "server/problem.hpp"
#include "server/upload.hpp"

#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <utility>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef HOCURVE_VERSION
#define HOCURVE_VERSION "0.0.0"
#endif
#ifndef HOCURVE_SOURCE_DIR
#define HOCURVE_SOURCE_DIR "."
#endif

namespace hocurve::server {
namespace fs = std::filesystem;
using httplib::ContentReader;
using httplib::Request;
using httplib::Response;

namespace {

/// /readyz says not ready below this much free disk in the data directory.
constexpr std::uintmax_t kMinFreeBytes = 16u << 20;

constexpr const char* kIdPattern = "([A-Za-z0-9_-]{1,64})";
constexpr const char* kProblemType = "application/problem+json";

// Per-request data of the HTTP worker thread that runs the request (pre-routing -> logger).
thread_local std::chrono::steady_clock::time_point t_request_start;
thread_local std::string t_request_id;
/// Set by stream_file: this answer honours Range (every other one says `Accept-Ranges: none`).
thread_local bool t_accept_ranges = false;

/// A MiB figure as people write it: "10240", "0.3".
std::string format_mib(double mib) {
  std::ostringstream out;
  out << std::setprecision(6) << mib;
  return out.str();
}

std::string new_request_id() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)rng());
  return buf;
}

void send_json(Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(json_text(body) + "\n", "application/json");
}

void send_problem(const Request& req, Response& res, int status, const std::string& type, const std::string& detail,
                  nlohmann::json extra = nlohmann::json::object()) {
  nlohmann::json p = make_problem(status, type, detail, extra);
  if (t_request_id.empty()) {  // refused by the HTTP parser, before pre-routing
    t_request_id = new_request_id();
    res.set_header("X-Request-Id", t_request_id);
  }
  p["instance"] = req.path;
  p["request_id"] = t_request_id;
  res.status = status;
  if (status == 429 || status == 503) res.set_header("Retry-After", "2");
  if (status == 401) res.set_header("WWW-Authenticate", "Bearer realm=\"hocurved\"");
  res.set_content(json_text(p) + "\n", kProblemType);
}

void send_problem(const Request& req, Response& res, const ApiError& e) {
  send_problem(req, res, e.status, e.type, e.what(), e.extra);
}

/// Route template for metrics labels (bounded set; never the raw path).
std::string route_of(const Request& req) {
  static const std::regex job(R"(^/v1/jobs/[A-Za-z0-9_-]{1,64}$)"), result(R"(^/v1/jobs/[A-Za-z0-9_-]{1,64}/result$)"),
      stats(R"(^/v1/jobs/[A-Za-z0-9_-]{1,64}/stats$)");
  const std::string& p = req.path;
  for (const char* fixed : {"/healthz", "/readyz", "/metrics", "/v1/info", "/v1/openapi.json", "/v1/jobs", "/v1/curve"})
    if (p == fixed) return fixed;
  if (p.size() < 200) {
    if (std::regex_match(p, job)) return "/v1/jobs/{id}";
    if (std::regex_match(p, result)) return "/v1/jobs/{id}/result";
    if (std::regex_match(p, stats)) return "/v1/jobs/{id}/stats";
  }
  return "other";
}

/// The methods a route answers (the Allow header of 405 and OPTIONS); empty for no route.
std::string allowed_methods(const std::string& route) {
  if (route == "other") return "";
  if (route == "/v1/jobs") return "GET, HEAD, POST, OPTIONS";
  if (route == "/v1/curve") return "POST, OPTIONS";
  if (route == "/v1/jobs/{id}") return "GET, HEAD, DELETE, OPTIONS";
  return "GET, HEAD, OPTIONS";
}

/// True when `allow` (an allowed_methods list) names `method`.
bool allows(const std::string& allow, const std::string& method) {
  size_t at = 0;
  while (at < allow.size()) {
    size_t end = allow.find(", ", at);
    if (end == std::string::npos) end = allow.size();
    if (allow.compare(at, end - at, method) == 0) return true;
    at = end + 2;
  }
  return false;
}

bool constant_time_equal(const std::string& given, const std::string& secret) {
  // Time depends only on the length of `given`, not on where the strings differ.
  size_t diff = given.size() ^ secret.size();
  for (size_t i = 0; i < given.size(); ++i)
    diff |= (unsigned char)given[i] ^ (unsigned char)(i < secret.size() ? secret[i] : 0);
  return diff == 0;
}

/// Wraps a handler: ApiError -> its problem, anything else -> 500 with the request id.
template <class F>
httplib::Server::Handler guarded(F f) {
  return [f](const Request& req, Response& res) {
    try {
      f(req, res);
    } catch (const ApiError& e) {
      send_problem(req, res, e);
    } catch (const std::exception& e) {
      log_error("handler failed", {{"request_id", t_request_id}, {"error", e.what()}});
      send_problem(req, res, 500, "internal", "internal error; quote request_id " + t_request_id);
    }
  };
}

template <class F>
httplib::Server::HandlerWithContentReader guarded_reader(F f) {
  return [f](const Request& req, Response& res, const ContentReader& reader) {
    try {
      f(req, res, reader);
    } catch (const ApiError& e) {
      send_problem(req, res, e);
    } catch (const std::exception& e) {
      log_error("handler failed", {{"request_id", t_request_id}, {"error", e.what()}});
      send_problem(req, res, 500, "internal", "internal error; quote request_id " + t_request_id);
    }
  };
}

/// An HTTP-date (RFC 9110 5.6.7) of a file time.
std::string http_date(time_t t) {
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
  return buf;
}

/// Streams a file from an open descriptor (the file may be unlinked meanwhile), 200. With
/// `ranges` (GET/HEAD of a stored result), a single byte Range is honoured (206, or 416 when it
/// lies past the end), unless an If-Range names another version (ETag or Last-Modified).
void stream_file(App& app, const Request& req, Response& res, const std::string& path, const std::string& download_name,
                 bool ranges) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw ApiError(404, "not-found", "result file is gone (expired or deleted)");
  struct stat st {};
  ::fstat(fd, &st);
  const std::uint64_t size = (std::uint64_t)st.st_size;
  ByteRange range;
  std::string etag, modified;
  if (ranges) {
    char tag[80];
    std::snprintf(tag, sizeof tag, "\"%llx-%llx-%llx\"", (unsigned long long)st.st_ino, (unsigned long long)size,
                  (unsigned long long)st.st_mtim.tv_sec * 1000000000ull + (unsigned long long)st.st_mtim.tv_nsec);
    etag = tag;
    modified = http_date(st.st_mtim.tv_sec);
    const std::string if_range = req.get_header_value("If-Range");
    if (req.method == "GET" && (if_range.empty() || if_range == etag || if_range == modified))
      range = parse_byte_range(range_header(req), size);
    if (range.kind == ByteRange::kUnsatisfiable) {
      ::close(fd);
      res.set_header("Content-Range", "bytes */" + std::to_string(size));
      throw ApiError(416, "range-not-satisfiable",
                     "the range '" + range_header(req).substr(0, 64) + "' lies outside the " +
                         std::to_string(size) + " bytes of the result");
    }
    t_accept_ranges = true;
    res.set_header("Accept-Ranges", "bytes");
    res.set_header("ETag", etag);
    res.set_header("Last-Modified", modified);
  }
  res.set_header("Content-Disposition", "attachment; filename=\"" + download_name + "\"");
  res.status = 200;
  std::uint64_t first = 0, length = size;
  if (range.kind == ByteRange::kPart) {
    res.status = 206;
    res.set_header("Content-Range", content_range(range, size));
    first = range.first;
    length = range.length;
  }
  if (length == 0) {  // an empty file: the library cannot provide zero bytes
    ::close(fd);
    res.set_content("", "application/octet-stream");
    return;
  }
  auto shared_fd = std::make_shared<int>(fd);
  res.set_content_provider(
      (size_t)length, "application/octet-stream",
      [shared_fd, &app, first](size_t offset, size_t length, httplib::DataSink& sink) {
        char buf[256 * 1024];
        size_t want = std::min(length, sizeof buf);
        ssize_t n = ::pread(*shared_fd, buf, want, (off_t)(first + offset));
        if (n <= 0 || !sink.is_writable()) return false;
        app.metrics.download_bytes += (std::uint64_t)n;
        return sink.write(buf, (size_t)n);
      },
      [shared_fd](bool) { ::close(*shared_fd); });
}

/// Everything POST /v1/jobs and POST /v1/curve share: upload, options, checks, job creation.
/// Returns the created (or replayed) job and whether it was a replay.
struct Created {
  Job job;
  bool replay = false;
};

Created create_job(App& app, const Request& req, Response& res, const ContentReader& reader, bool sync) {
  if (app.draining) {
    discard_body(req, res, reader);
    throw ApiError(503, "draining", "server is shutting down; retry on another instance or later");
  }
  if (const std::string why = app.store.check_storage(); !why.empty()) {
    discard_body(req, res, reader);
    throw ApiError(503, "storage-unavailable", why);
  }
  // Cheap refusals first, before reading the body.
  if (!sync && (int)app.runner.queue_depth() >= app.config.max_queue) {
    discard_body(req, res, reader);
    app.metrics.rejected_queue_full++;
    throw ApiError(429, "queue-full",
                   "the queue holds " + std::to_string(app.config.max_queue) + " jobs already; retry later");
  }
  // Options from the query string are validated before the upload is read. cpp-httplib drops what
  // follows a ';' in a parameter, where other parsers split there: `order=3;order=4` meant 3 here
  // and 4 elsewhere, so ';' is refused.
  if (req.target.find(';', std::min(req.target.find('?'), req.target.size())) != std::string::npos) {
    discard_body(req, res, reader);
    throw ApiError(400, "invalid-options", "the query holds a ';': separate parameters with '&'");
  }
  nlohmann::json raw = options_from_query(req.params);
  std::set<std::string> query_keys;  // text; the multipart options part is JSON
  for (auto& [k, _] : raw.items()) query_keys.insert(k);
  const bool multipart = req.is_multipart_form_data();
  if (!multipart) {
    try {
      normalise_options(raw);
    } catch (const ApiError&) {
      discard_body(req, res, reader);
      throw;
    }
  }
  std::string key = req.get_header_value("Idempotency-Key");
  const bool control = std::any_of(key.begin(), key.end(), [](char c) { return (unsigned char)c < 0x20 || c == 0x7f; });
  if (key.size() > 255 || control || key.find('"') != std::string::npos || !is_utf8(key)) {
    discard_body(req, res, reader);
    throw ApiError(400, "invalid-request", "Idempotency-Key must be at most 255 printable characters of UTF-8");
  }
  if (!key.empty()) {
    std::lock_guard<std::mutex> lock(app.keys_mutex);
    if (!app.keys_in_flight.insert(key).second) {
      discard_body(req, res, reader);
      throw ApiError(409, "idempotency-in-flight", "a request with Idempotency-Key '" + key + "' is still being processed");
    }
  }
  struct KeyRelease {
    App& app;
    std::string key;
    ~KeyRelease() {
      if (key.empty()) return;
      std::lock_guard<std::mutex> lock(app.keys_mutex);
      app.keys_in_flight.erase(key);
    }
  } release{app, key};

  const double cap_mb = sync ? app.config.max_sync_mb : app.config.max_upload_mb;
  const std::uint64_t cap = (std::uint64_t)(cap_mb * 1024 * 1024);
  // The declared length is set aside in the quota until the upload is a job (counted then) or
  // gone; above the upload limit it is 413 (receive_upload says so) before the quota's 507.
  struct Reservation {
    JobStore& store;
    std::uint64_t bytes = 0;
    ~Reservation() { store.release(bytes); }
  } reservation{app.store};
  if (req.has_header("Content-Length")) {
    const std::string cl = req.get_header_value("Content-Length");
    if (cl.find_first_not_of("0123456789") == std::string::npos && cl.size() < 18 && std::stoull(cl) <= cap) {
      if (!app.store.reserve(std::stoull(cl), (std::uint64_t)(app.config.max_disk_mb * 1024 * 1024))) {
        discard_body(req, res, reader);
        throw ApiError(507, "quota-exceeded", "the data directory quota (" + format_mib(app.config.max_disk_mb) +
                                                  " MiB) is used up; delete jobs or retry later");
      }
      reservation.bytes = std::stoull(cl);
    }
  }
  if (!req.has_header("Content-Length")) {
    discard_body(req, res, reader);
    throw ApiError(411, "length-required", "uploads need a Content-Length header (chunked bodies are not accepted)");
  }
  Upload up;
  bool reading = false;
  try {
    up = receive_upload(req, reader, cap, app.store.uploads_dir(), &reading);
  } catch (const ApiError&) {
    // Refused before reading (413 on Content-Length, 415): drop a small body, else close: once
    // reading, the rest of the body is not wanted (the connection ends with the answer).
    if (!reading) discard_body(req, res, reader);
    else res.set_header("Connection", "close");
    throw;
  }
  app.metrics.upload_bytes += up.bytes;
  auto drop = [&](ApiError e) -> ApiError {
    remove_quietly(up.path);
    return e;
  };
  nlohmann::json options;
  try {
    if (multipart && !up.options_json.empty()) {
      nlohmann::json part = nlohmann::json::parse(up.options_json, nullptr, false);
      if (part.is_discarded())
        throw ApiError(400, "invalid-json", "the 'options' part is not valid JSON");
      if (!part.is_object()) throw ApiError(400, "invalid-options", "the 'options' part must be a JSON object");
      for (auto& [k, v] : part.items()) {
        if (raw.contains(k))
          throw ApiError(400, "invalid-options", "option '" + k + "' given both in the query and in the options part");
        raw[k] = v;
      }
    }
    options = normalise_options(raw, &query_keys);
  } catch (const ApiError& e) {
    throw drop(e);
  }
  SniffResult sniff = sniff_mesh(up.head, up.bytes, up.filename);
  if (!sniff.refusal.empty()) throw drop(ApiError(422, "invalid-mesh", sniff.refusal, {{"format", sniff.format}}));
  if (sniff.format.empty())
    throw drop(ApiError(415, "unsupported-media-type",
                        "unknown mesh format: the upload is not STL, OBJ, PLY, OFF or Gmsh .msh (optionally gzipped)"));
  const std::string fingerprint = up.fingerprint + ":" + json_text(options);

  if (!key.empty()) {
    if (auto prior = app.store.find_idempotent(key)) {
      remove_quietly(up.path);
      if (prior->fingerprint != fingerprint)
        throw ApiError(422, "idempotency-key-reused",
                       "Idempotency-Key '" + key + "' was used for job " + prior->id + " with a different mesh or options");
      return {*prior, true};
    }
  }
  Job job;
  job.id = app.store.new_id();
  job.created = now_seconds();
  job.options = options;
  job.sync = sync;
  job.idempotency_key = key;
  job.fingerprint = fingerprint;
  const std::string filename = "input" + sniff.extension;
  job.input = {{"filename", filename}, {"format", sniff.format}, {"bytes", up.bytes}};
  if (!up.filename.empty()) job.input["client_filename"] = up.filename;
  const std::string dir = app.store.job_dir(job.id);
  fs::create_directories(dir);
  if (::rename(up.path.c_str(), (dir + "/" + filename).c_str()) != 0) {
    remove_quietly(up.path);
    fs::remove_all(dir);
    throw ApiError(500, "internal", "cannot move the upload into the job folder");
  }
  try {
    app.store.insert(job);
  } catch (const std::exception& e) {  // the state could not be saved: leave nothing behind
    std::error_code ec;
    fs::remove_all(dir, ec);
    throw ApiError(503, "storage-unavailable", std::string("cannot save the job's state: ") + e.what());
  }
  if (!app.runner.enqueue(job.id, false, sync)) {
    app.store.remove(job.id);
    app.metrics.rejected_queue_full++;
    throw ApiError(429, "queue-full", "the queue is full; retry later");
  }
  app.metrics.job_submitted(options.value("mode", "curve"));
  log_info("job submitted", {{"job_id", job.id}, {"request_id", t_request_id}, {"bytes", up.bytes},
                             {"format", sniff.format}, {"options", options}, {"sync", sync}});
  return {job, false};
}

Job require_job(App& app, const Request& req) {
  // A finished job is saved before it is reported (wait_terminal saves what its updater has not yet):
  // what a client is told survives a crash, and the job's folder holds no half-written state.json.
  auto job = app.store.wait_terminal(req.matches[1].str(), 0);
  if (!job || job->sync) throw ApiError(404, "not-found", "no job with id '" + req.matches[1].str() + "'");
  return *job;
}

/// `what`: the resource asked for ("result", "stats").
void require_succeeded(const Job& job, const std::string& what) {
  if (job.status != "succeeded")
    throw ApiError(409, "job-state-conflict",
                   "job " + job.id + " is " + job.status + "; its " + what + " exist" + (what == "stats" ? "" : "s") +
                       " only once it has succeeded",
                   {{"job_status", job.status}});
}

}  // namespace

nlohmann::json load_openapi(const std::string& exe_dir) {
  std::vector<std::string> candidates;
  if (const char* p = std::getenv("HOCURVE_OPENAPI"); p && *p) candidates.push_back(p);
  candidates.push_back(exe_dir + "/../share/hocurve/openapi.yaml");
  candidates.push_back(exe_dir + "/openapi.yaml");
  candidates.push_back(std::string(HOCURVE_SOURCE_DIR) + "/api/openapi.yaml");
  for (auto& c : candidates) {
    std::ifstream in(c);
    if (!in) continue;
    // api/openapi.yaml is written in the JSON subset of YAML, so nlohmann can read it.
    nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
    if (!doc.is_discarded()) return doc;
    log_warn("openapi document is not JSON-compatible YAML", {{"path", c}});
  }
  return nullptr;
}

void install_routes(httplib::Server& svr, App& app) {
  svr.set_pre_routing_handler([&app](const Request& req, Response& res) {
    t_request_start = std::chrono::steady_clock::now();
    std::string rid = req.get_header_value("X-Request-Id");
    if (rid.empty() || rid.size() > 64 || rid.find_first_not_of("0123456789abcdefABCDEF-_") != std::string::npos)
      rid = new_request_id();
    t_request_id = rid;
    res.set_header("X-Request-Id", rid);
    if (req.path.size() > 256) {
      send_problem(req, res, 414, "uri-too-long", "request path longer than 256 bytes");
      res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    }
    {  // an encoded '/' would let one id name another resource: paths are matched as sent
      const std::string raw_path = req.target.substr(0, req.target.find('?'));
      if (raw_path.find("%2F") != std::string::npos || raw_path.find("%2f") != std::string::npos) {
        send_problem(req, res, 404, "not-found", "no such resource (the path holds an encoded '/')");
        res.set_header("Connection", "close");  // a body, if any, is not read
        return httplib::Server::HandlerResponse::Handled;
      }
    }
    if (req.has_header("Content-Encoding")) {
      send_problem(req, res, 415, "unsupported-media-type", "Content-Encoding is not accepted; gzip the mesh file itself instead");
      res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    }
    // Range is applied by stream_file to results only (the library would apply it to any answer,
    // JSON and problems included, and 0.11 checks no bounds for streamed ones).
    const_cast<Request&>(req).ranges.clear();
    t_accept_ranges = false;
    const bool has_body = req.has_header("Content-Length") || req.has_header("Transfer-Encoding");
    const std::string allow = allowed_methods(route_of(req));
    if (!allow.empty() && req.method == "OPTIONS") {
      res.status = 204;
      res.set_header("Allow", allow);
      if (has_body) res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!allow.empty() && !allows(allow, req.method)) {
      send_problem(req, res, 405, "method-not-allowed", req.method + " is not allowed on " + req.path + "; allowed: " + allow);
      res.set_header("Allow", allow);
      if (has_body) res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    }
    if ((req.method == "POST" || req.method == "PUT" || req.method == "PATCH") && !has_body) {
      // Without a length the library would wait for the client to close the connection.
      send_problem(req, res, 411, "length-required", req.method + " needs a Content-Length header (use Content-Length: 0 for no body)");
      res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!app.config.token.empty() && req.path.rfind("/v1/", 0) == 0) {
      const std::string auth = req.get_header_value("Authorization");
      const std::string scheme = "bearer ";  // case-insensitive, then 1*SP (RFC 9110 11.1, 11.4)
      bool ok = auth.size() > scheme.size() &&
                std::equal(scheme.begin(), scheme.end(), auth.begin(),
                           [](char a, char b) { return a == std::tolower((unsigned char)b); });
      if (ok) {
        const size_t credentials = auth.find_first_not_of(' ', scheme.size());
        ok = credentials != std::string::npos && constant_time_equal(auth.substr(credentials), app.config.token);
      }
      if (!ok) {
        send_problem(req, res, 401, "unauthorized", "this server needs 'Authorization: Bearer <token>'");
        res.set_header("Connection", "close");
        return httplib::Server::HandlerResponse::Handled;
      }
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });

  svr.set_error_handler(httplib::Server::HandlerWithResponse([](const Request& req, Response& res) {
    if (!res.body.empty() || res.content_length_ > 0) return httplib::Server::HandlerResponse::Unhandled;
    if (request_read_timed_out()) res.status = 408;  // the client stopped sending mid-request
    switch (res.status) {
      case 408:
        send_problem(req, res, 408, "request-timeout", "the client sent nothing for longer than the read timeout");
        break;
      case 404: send_problem(req, res, 404, "not-found", "no resource at " + req.method + " " + req.path); break;
      case 405: send_problem(req, res, 405, "method-not-allowed", req.method + " is not allowed on " + req.path); break;
      case 413: send_problem(req, res, 413, "payload-too-large", "request body too large"); break;
      case 414: send_problem(req, res, 414, "uri-too-long", "request URI too long"); break;
      case 416: send_problem(req, res, 416, "range-not-satisfiable", "range not satisfiable"); break;
      case 400:
        send_problem(req, res, 400, "invalid-request",
                     req.method.empty() || req.path.empty()
                         ? "malformed request: the request line or a header could not be parsed (headers are limited to 8 KiB)"
                     : !known_http_method(req.method)
                         ? "unsupported method '" + req.method.substr(0, 16) + "'"
                         : "request could not be processed: a malformed or over-long header (8 KiB per line), or a body that could not be read");
        break;
      default:
        send_problem(req, res, res.status, res.status >= 500 ? "internal" : "invalid-request",
                     "request could not be processed (HTTP " + std::to_string(res.status) + ")");
    }
    // The library refused the request while reading it: where it stopped (mid header, mid body)
    // is no place to read the next request from (a 416 of the library left the body unread too).
    if (res.status != 404 && res.status != 405) res.set_header("Connection", "close");
    return httplib::Server::HandlerResponse::Handled;
  }));

  svr.set_post_routing_handler([](const Request&, Response& res) {
    // The library says "Accept-Ranges: bytes" on every HEAD answer; only results honour Range.
    if (!std::exchange(t_accept_ranges, false) && res.has_header("Accept-Ranges")) {
      res.headers.erase("Accept-Ranges");
      res.set_header("Accept-Ranges", "none");
    }
    // An answer that says so ends its connection (the library would read on: the rest of a refused
    // body, or requests pipelined behind it that the client will send again).
    // One Connection header: handlers and the library (for a client's own "close") each add one.
    if (res.get_header_value_count("Connection") > 1) {
      bool close = false;
      for (size_t i = 0; i < res.get_header_value_count("Connection"); ++i)
        close |= res.get_header_value("Connection", i) == "close";
      const std::string first = res.get_header_value("Connection");
      res.headers.erase("Connection");
      res.set_header("Connection", close ? "close" : first);
    }
    if (res.get_header_value("Connection") == "close") {
      res.headers.erase("Keep-Alive");
      close_connection_after_response();
    }
  });

  svr.set_exception_handler([](const Request& req, Response& res, std::exception_ptr) {
    send_problem(req, res, 500, "internal", "internal error; quote request_id " + t_request_id);
    res.set_header("Connection", "close");  // the body may be unread
  });

  svr.set_logger([&app](const Request& req, const Response& res) {
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_request_start).count();
    std::string route = route_of(req);
    app.metrics.count_request(req.method, route, res.status, seconds);
    const std::string rid = std::move(t_request_id);
    t_request_id.clear();  // the next request on this thread may fail before pre-routing sets one
    if (route == "/healthz" || route == "/readyz" || route == "/metrics") return;  // probes would drown the log
    log_info("request", {{"request_id", rid}, {"method", req.method.substr(0, 16)}, {"route", route},
                         {"path", req.path.substr(0, 256)}, {"status", res.status},
                         {"duration_ms", std::round(seconds * 1e4) / 10}});
  });

  svr.Get("/healthz", [](const Request&, Response& res) { send_json(res, 200, {{"status", "ok"}}); });
  svr.Get("/readyz", [&app](const Request& req, Response& res) {
    if (app.draining) return send_problem(req, res, 503, "draining", "server is shutting down");
    if (const std::string why = app.store.check_storage(); !why.empty())
      return send_problem(req, res, 503, "storage-unavailable", why);
    if (::access(app.store.uploads_dir().c_str(), W_OK) != 0)
      return send_problem(req, res, 503, "storage-unavailable",
                          std::string("the data directory is not writable: ") + std::strerror(errno));
    // A disk with no room fails every upload and every result write.
    std::error_code ec;
    const auto space = fs::space(app.store.uploads_dir(), ec);
    if (!ec && space.available < kMinFreeBytes)
      return send_problem(req, res, 503, "storage-full",
                          "the data directory's disk has " + std::to_string(space.available / 1024) + " KiB free");
    if (::access(app.runner.worker_bin().c_str(), X_OK) != 0)
      return send_problem(req, res, 503, "internal",
                          "the worker program '" + app.runner.worker_bin() + "' cannot be executed: " + std::strerror(errno));
    send_json(res, 200, {{"status", "ready"}, {"queue_depth", app.runner.queue_depth()}, {"running", app.runner.running()}});
  });
  svr.Get("/metrics", [&app](const Request&, Response& res) {
    GaugeSnapshot g;
    g.jobs_by_state = app.store.counts();
    g.queue_depth = (long long)app.runner.queue_depth();
    g.running = (long long)app.runner.running();
    g.queue_capacity = app.config.max_queue;
    g.workers = app.config.workers;
    g.disk_bytes = app.store.disk_bytes();
    g.disk_quota_bytes = (std::uint64_t)(app.config.max_disk_mb * 1024 * 1024);
    g.ready = !app.draining;
    res.status = 200;
    res.set_content(app.metrics.render(g, HOCURVE_VERSION), "text/plain; version=0.0.4; charset=utf-8");
  });
  svr.Get("/v1/info", [&app](const Request&, Response& res) {
    std::vector<int> orders;
    for (int p = kMinOrder; p <= kMaxOrder; ++p) orders.push_back(p);
    send_json(res, 200,
              {{"name", "hocurved"},
               {"version", HOCURVE_VERSION},
               {"api_version", "1.0.0"},
               {"orders", orders},
               {"modes", {"curve", "coarsen"}},
               {"nodes", {"equispaced", "lobatto"}},
               {"input_formats", {"stl", "obj", "ply", "off", "msh", "gzip"}},
               {"output_formats", {"msh41", "msh22"}},
               {"limits",
                {{"max_upload_bytes", (std::uint64_t)(app.config.max_upload_mb * 1048576)},
                 {"max_sync_upload_bytes", (std::uint64_t)(app.config.max_sync_mb * 1048576)},
                 {"max_queue", app.config.max_queue},
                 {"workers", app.config.workers},
                 {"job_timeout_seconds", app.config.job_timeout},
                 {"job_memory_bytes", (std::uint64_t)(app.config.job_memory_mb * 1048576)},
                 {"retention_seconds", app.config.retention},
                 {"max_disk_bytes", (std::uint64_t)(app.config.max_disk_mb * 1048576)},
                 {"max_page_size", 500}}},
               {"auth", app.config.token.empty() ? "none" : "bearer"}});
  });
  svr.Get("/v1/openapi.json", guarded([&app](const Request&, Response& res) {
            if (app.openapi.is_null()) throw ApiError(404, "not-found", "the OpenAPI document was not found at start-up");
            send_json(res, 200, app.openapi);
          }));

  svr.Post("/v1/jobs", guarded_reader([&app](const Request& req, Response& res, const ContentReader& reader) {
             Created c = create_job(app, req, res, reader, false);
             res.set_header("Location", "/v1/jobs/" + c.job.id);
             res.set_header("Retry-After", "1");
             if (c.replay) res.set_header("Idempotent-Replayed", "true");
             send_json(res, 202, job_view(c.job));
           }));
  svr.Post("/v1/curve", guarded_reader([&app](const Request& req, Response& res, const ContentReader& reader) {
             Created c = create_job(app, req, res, reader, true);
             // A client that hangs up no longer wants the result: its job is cancelled, so that
             // abandoned requests do not keep the workers busy. One that only shut down its
             // sending side still waits for the answer (PeerWatch tells them apart). Not a
             // replay's: that job is another request's.
             PeerWatch peer(c.replay ? -1 : current_connection_socket(), req.version == "HTTP/1.1");
             const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(app.config.job_timeout + 30);
             auto done = app.store.wait_terminal(c.job.id, 0.5);
             while (done && !done->terminal() && std::chrono::steady_clock::now() < deadline) {
               if (peer.gone()) {
                 app.runner.cancel(c.job.id);
                 done = app.store.wait_terminal(c.job.id, 5.0);
                 log_info("sync job cancelled: the client hung up", {{"job_id", c.job.id}, {"request_id", t_request_id}});
                 break;
               }
               done = app.store.wait_terminal(c.job.id, 0.5);
             }
             struct Cleanup {
               App& app;
               std::string id;
               bool replay;
               ~Cleanup() {
                 if (!replay) app.store.remove(id);
               }
             } cleanup{app, c.job.id, c.replay};
             if (!done) throw ApiError(500, "internal", "the job disappeared (cancelled by shutdown?)");
             if (!done->terminal()) {
               app.runner.cancel(done->id);
               throw ApiError(504, "timeout", "the job did not finish in time");
             }
             if (done->status != "succeeded") {
               nlohmann::json e = done->error.is_object() ? done->error : make_problem(500, "internal", "job failed");
               int status = e.value("status", 500);
               std::string type = e.value("code", "internal");
               throw ApiError(status, type, e.value("detail", "job failed"));
             }
             res.set_header("X-Job-Id", done->id);
             if (done->stats.is_object()) {
               std::string s = json_text(done->stats);
               if (s.size() < 4000) res.set_header("X-Hocurve-Stats", s);
             }
             stream_file(app, req, res, app.store.job_dir(done->id) + "/result.msh", "curved.msh", false);
           }));

  svr.Get("/v1/jobs", guarded([&app](const Request& req, Response& res) {
            static const std::set<std::string> known = {"page_size", "page_token", "status"};
            for (auto& [k, _] : req.params)
              if (!known.count(k)) throw ApiError(400, "invalid-request", "unknown query parameter '" + k + "'");
            size_t page_size = 50;
            if (req.has_param("page_size")) {
              std::string v = req.get_param_value("page_size");
              if (v.empty() || v.size() > 9 || v.find_first_not_of("0123456789") != std::string::npos)
                throw ApiError(400, "invalid-request", "page_size must be a non-negative integer, got '" + v + "'");
              page_size = std::stoul(v);
              if (page_size == 0) page_size = 50;
              page_size = std::min<size_t>(page_size, 500);  // coerced, never rejected
            }
            std::string status = req.get_param_value("status");
            if (!status.empty() && status != "queued" && status != "running" && status != "succeeded" &&
                status != "failed" && status != "cancelled")
              throw ApiError(400, "invalid-request", "status filter must be queued|running|succeeded|failed|cancelled");
            std::string token = req.get_param_value("page_token");
            std::string after;
            if (!token.empty()) {
              // Opaque to clients: "<status filter>~<last id>"; the filter must match the request's.
              static const std::regex tok(R"(^([a-z]*)~([0-9a-f]{24})$)");
              std::smatch m;
              if (token.size() > 64 || !std::regex_match(token, m, tok) || m[1].str() != status)
                throw ApiError(400, "invalid-page-token", "page_token is malformed or belongs to a different query");
              after = m[2].str();
            }
            bool more = false;
            auto jobs = app.store.list(page_size, after, status, more);
            // As for one job (require_job): a finished job is saved before it is listed as finished.
            for (auto& j : jobs)
              if (j.terminal())
                if (auto saved = app.store.wait_terminal(j.id, 0)) j = *saved;
            nlohmann::json out = {{"jobs", nlohmann::json::array()}, {"next_page_token", ""}};
            for (auto& j : jobs) out["jobs"].push_back(job_view(j));
            if (more && !jobs.empty()) out["next_page_token"] = status + "~" + jobs.back().id;
            res.set_header("Cache-Control", "no-store");
            send_json(res, 200, out);
          }));

  svr.Get(std::string("/v1/jobs/") + kIdPattern, guarded([&app](const Request& req, Response& res) {
            Job job = require_job(app, req);
            res.set_header("Cache-Control", "no-store");
            if (!job.terminal()) res.set_header("Retry-After", "1");
            send_json(res, 200, job_view(job));
          }));
  svr.Get(std::string("/v1/jobs/") + kIdPattern + "/result", guarded([&app](const Request& req, Response& res) {
            Job job = require_job(app, req);
            require_succeeded(job, "result");
            stream_file(app, req, res, app.store.job_dir(job.id) + "/result.msh", job.id + ".msh", true);
          }));
  svr.Get(std::string("/v1/jobs/") + kIdPattern + "/stats", guarded([&app](const Request& req, Response& res) {
            Job job = require_job(app, req);
            require_succeeded(job, "stats");
            send_json(res, 200, job.stats.is_null() ? nlohmann::json::object() : job.stats);
          }));
  svr.Delete(std::string("/v1/jobs/") + kIdPattern, guarded([&app](const Request& req, Response& res) {
               Job job = require_job(app, req);
               if (job.terminal()) {
                 std::string error;
                 if (!app.store.remove(job.id, &error) && !error.empty())
                   throw ApiError(503, "storage-unavailable", "job " + job.id + " was not deleted: " + error);
                 log_info("job deleted", {{"job_id", job.id}, {"request_id", t_request_id}});
                 res.status = 204;
                 return;
               }
               app.runner.cancel(job.id);
               // A running job ends "cancelled" once its process is gone (milliseconds).
               auto now = app.store.wait_terminal(job.id, 5.0);
               log_info("job cancel requested", {{"job_id", job.id}, {"request_id", t_request_id}});
               send_json(res, 202, job_view(now ? *now : job));
             }));
}

}  // namespace hocurve::server
