#include "server/problem.hpp"

#include <map>

namespace hocurve::server {

std::string problem_title(const std::string& type) {
  static const std::map<std::string, std::string> titles = {
      {"invalid-options", "Invalid job options"},
      {"invalid-json", "Malformed JSON"},
      {"invalid-request", "Invalid request"},
      {"invalid-page-token", "Invalid page token"},
      {"invalid-mesh", "Mesh refused"},
      {"unauthorized", "Missing or wrong bearer token"},
      {"not-found", "Not found"},
      {"method-not-allowed", "Method not allowed"},
      {"job-state-conflict", "Job is in the wrong state"},
      {"idempotency-in-flight", "A request with this Idempotency-Key is still being processed"},
      {"idempotency-key-reused", "Idempotency-Key reused with a different request"},
      {"length-required", "Content-Length required"},
      {"request-timeout", "Request too slow"},
      {"header-too-large", "Request header fields too large"},
      {"not-implemented", "Transfer coding not supported"},
      {"server-busy", "Too many connections"},
      {"payload-too-large", "Upload or mesh too large"},
      {"uri-too-long", "URI too long"},
      {"unsupported-media-type", "Unsupported media type or mesh format"},
      {"range-not-satisfiable", "Range not supported"},
      {"queue-full", "Job queue is full"},
      {"quota-exceeded", "Disk quota exceeded"},
      {"storage-unavailable", "Data directory not writable"},
      {"storage-full", "Data directory's disk full"},
      {"draining", "Server is shutting down"},
      {"job-failed", "Job failed"},
      {"timeout", "Job timed out"},
      {"worker-crashed", "Worker process crashed"},
      {"cancelled", "Job cancelled"},
      {"internal", "Internal error"},
  };
  auto it = titles.find(type);
  return it == titles.end() ? std::string("Error") : it->second;
}

nlohmann::json make_problem(int status, const std::string& type, const std::string& detail,
                            const nlohmann::json& extra) {
  nlohmann::json p = {{"type", std::string(kProblemBase) + type},
                      {"title", problem_title(type)},
                      {"status", status},
                      {"detail", detail},
                      {"code", type}};
  if (extra.is_object())
    for (auto& [k, v] : extra.items()) p[k] = v;
  return p;
}

}  // namespace hocurve::server
