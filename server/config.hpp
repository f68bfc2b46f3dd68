// hocurved configuration: defaults, then HOCURVE_* environment variables, then command-line flags.
#pragma once
#include <string>
#include <vector>

namespace hocurve::server {

struct Config {
  std::string host = "127.0.0.1";
  int port = 8080;                   ///< 0 = ephemeral; the bound port is logged first
  std::string data_dir = "./hocurved-data";
  int workers = 2;                   ///< concurrent jobs (worker processes)
  int http_threads = 64;             ///< HTTP connection threads (each open connection holds one)
  double client_timeout = 10;        ///< seconds for a request head to arrive whole; longest silence in a body
  int job_threads = 1;               ///< --threads passed to each worker
  double max_upload_mb = 64;         ///< POST /v1/jobs body cap
  double max_sync_mb = 4;            ///< POST /v1/curve body cap
  int max_queue = 64;                ///< queued (not running) jobs before 429
  double job_timeout = 600;          ///< seconds of wall time per job
  double job_memory_mb = 4096;       ///< RLIMIT_AS of each worker
  double retention = 86400;          ///< seconds a finished job is kept
  double max_disk_mb = 10240;        ///< quota over the data directory
  double shutdown_grace = 20;        ///< seconds SIGTERM waits for running jobs
  int max_attempts = 3;              ///< runs of one job across restarts before it fails
  std::string token_file;            ///< optional bearer token
  std::string hocurve_bin;           ///< worker program; default: next to hocurved
  std::string token;                 ///< loaded from token_file
};

/// Reads HOCURVE_* variables then flags (`--name value` or `--name=value`). Throws std::runtime_error
/// naming the bad flag. Returns false when --help was printed.
bool parse_config(int argc, char** argv, Config& config);

/// Usage text.
std::string config_usage();

/// Locates the worker: --hocurve-bin, HOCURVE_BIN, then `hocurve` next to `argv0`.
std::string locate_worker(const std::string& configured, const char* argv0);

}  // namespace hocurve::server
