// hocurved: the HTTP/JSON job service. Binds, recovers the job store, serves until SIGTERM/SIGINT,
// then drains (not ready, running jobs get a grace period, the rest stay queued on disk) and stops.
#include "server/app.hpp"
#include "server/http_server.hpp"
#include "server/log.hpp"

#include <httplib.h>

#include <csignal>
#include <filesystem>
#include <iostream>
#include <thread>
#include <sys/resource.h>
#include <unistd.h>

#ifndef HOCURVE_VERSION
#define HOCURVE_VERSION "0.0.0"
#endif

using namespace hocurve::server;

int main(int argc, char** argv) {
  // Block the termination signals in every thread; one thread waits for them with sigwait.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  Config config;
  try {
    if (!parse_config(argc, argv, config)) return 0;
  } catch (const std::exception& e) {
    std::cerr << "hocurved: " << e.what() << "\n";
    return 2;
  }
  const std::string worker = locate_worker(config.hocurve_bin, argv[0]);
  std::error_code ec;
  const std::string exe_dir = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path().string();

  // The data directory first: its lock keeps a second daemon off the same jobs.
  std::unique_ptr<App> app;
  try {
    app = std::make_unique<App>(config, worker);
  } catch (const std::exception& e) {
    log_error("cannot open the data directory", {{"data_dir", config.data_dir}, {"error", e.what()}});
    return 1;
  }

  HttpServer svr;  // keeps pipelined requests and serves half-closed clients (http_server.hpp)
  // SO_REUSEADDR only: the library's default SO_REUSEPORT let a second daemon bind the same port
  // and take half the connections.
  svr.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  const int threads = config.http_threads;
  svr.new_task_queue = [threads] { return new httplib::ThreadPool((size_t)threads); };
  // A pool thread serves one request at a time; heads are read by the front end (http_server.hpp),
  // so idle and slow clients hold no thread. Slow bodies are cut off (upload.cpp, read timeout).
  svr.set_keep_alive_max_count(5);
  svr.set_keep_alive_timeout(1);
  const auto client_us = (long long)(config.client_timeout * 1e6);
  svr.set_read_timeout(client_us / 1000000, client_us % 1000000);
  svr.set_write_timeout(30);
  svr.set_payload_max_length((size_t)(std::max(config.max_upload_mb, config.max_sync_mb) * 1048576) + (1u << 20));
  FrontLimits limits;
  limits.head_seconds = config.client_timeout;
  {  // each waiting connection holds a descriptor: take what the hard limit allows
    rlimit nofile{};
    if (::getrlimit(RLIMIT_NOFILE, &nofile) == 0) {
      nofile.rlim_cur = nofile.rlim_max;
      ::setrlimit(RLIMIT_NOFILE, &nofile);
      ::getrlimit(RLIMIT_NOFILE, &nofile);
      const rlim_t spare = 256 + 2 * (rlim_t)threads;  // jobs, store, pool connections
      limits.connections = nofile.rlim_cur > spare + 64 ? (size_t)std::min<rlim_t>(nofile.rlim_cur - spare, 65536) : 64;
    }
  }
  svr.set_front_limits(limits);

  int port = config.port;
  if (port == 0) {
    port = svr.bind_to_any_port(config.host);
    if (port <= 0) {
      log_error("cannot bind", {{"host", config.host}, {"port", 0}});
      return 1;
    }
  } else if (!svr.bind_to_port(config.host, port)) {
    log_error("cannot bind (address in use?)", {{"host", config.host}, {"port", port}});
    return 1;
  }
  log_info("listening", {{"host", config.host}, {"port", port}, {"version", HOCURVE_VERSION}, {"pid", ::getpid()}});

  if (::access(worker.c_str(), X_OK) != 0)
    log_warn("worker program not found or not executable; jobs will fail", {{"hocurve_bin", worker}});
  app->openapi = load_openapi(exe_dir);

  // Recovery: finished jobs stay listed; queued or interrupted ones run again, oldest first.
  int requeued = 0, dropped = 0;
  for (const Job& j : app->store.load()) {
    if (j.terminal()) continue;
    if (j.sync) {  // its client is gone
      app->store.remove(j.id);
      ++dropped;
      continue;
    }
    app->store.update(j.id, [](Job& x) {
      x.status = "queued";
      x.stage = "queued";
      x.fraction = 0;
    });
    app->runner.enqueue(j.id, /*force=*/true);
    ++requeued;
  }
  log_info("store loaded", {{"data_dir", config.data_dir}, {"requeued", requeued}, {"dropped_sync", dropped},
                            {"hocurve_bin", worker}, {"workers", config.workers}});
  app->runner.start();
  install_routes(svr, *app);
  App& a = *app;  // requests the front end refuses count as those of no route
  svr.set_refusal_counter([&a](const std::string& method, int status) { a.metrics.count_request(method, "other", status, 0); });

  std::thread http([&svr] { svr.serve(); });
  int sig = 0;
  sigwait(&signals, &sig);
  log_info("draining", {{"signal", sig}, {"running", app->runner.running()}, {"queued", app->runner.queue_depth()}});
  app->draining = true;
  app->runner.shutdown(config.shutdown_grace);
  svr.halt();
  http.join();
  log_info("stopped", nlohmann::json::object());
  return 0;
}
