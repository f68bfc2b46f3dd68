// The daemon's shared state, handed to the HTTP routes: configuration, store, runner, metrics.
#pragma once
#include "server/config.hpp"
#include "server/job_runner.hpp"
#include "server/job_store.hpp"
#include "server/metrics.hpp"

#include <atomic>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

namespace httplib {
class Server;
}

namespace hocurve::server {

struct App {
  App(Config c, std::string worker_bin)
      : config(std::move(c)), store(config.data_dir), runner(config, std::move(worker_bin), store, metrics) {}
  Config config;
  Metrics metrics;
  JobStore store;
  JobRunner runner;
  std::atomic<bool> draining{false};
  nlohmann::json openapi;  ///< the OpenAPI document, served at /v1/openapi.json
  std::mutex keys_mutex;
  std::set<std::string> keys_in_flight;  ///< Idempotency-Keys whose first request is being processed
};

/// Installs every route, the pre-routing checks (auth, limits), the problem+json error handlers
/// and the access log on `server`.
void install_routes(httplib::Server& server, App& app);

/// Loads the OpenAPI document (JSON-compatible YAML) from the first readable candidate path.
nlohmann::json load_openapi(const std::string& exe_dir);

}  // namespace hocurve::server
