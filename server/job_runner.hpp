// Runs jobs off the HTTP threads: a bounded queue and a fixed number of worker threads, each of
// which runs one job at a time in a separate `hocurve` process (own process group, RLIMIT_AS,
// wall-clock timeout), reads its --progress JSON lines and records the outcome in the JobStore.
#pragma once
#include "server/config.hpp"
#include "server/job_store.hpp"
#include "server/metrics.hpp"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <sys/types.h>
#include <thread>
#include <vector>

namespace hocurve::server {

class JobRunner {
 public:
  JobRunner(const Config& config, std::string worker_bin, JobStore& store, Metrics& metrics);
  ~JobRunner();

  /// Starts the worker threads and the janitor (retention).
  void start();
  /// Queues a job. Returns false when `max_queue` jobs are already waiting, unless `force`
  /// (jobs recovered at start-up). `front` puts it first (synchronous requests).
  bool enqueue(const std::string& id, bool force = false, bool front = false);
  /// Cancels a queued job at once, or kills a running job's process group; the job ends "cancelled".
  void cancel(const std::string& id);
  /// Stops taking jobs, lets running ones finish for `grace_s`, then kills the rest and leaves
  /// them "queued" on disk so the next start runs them again. Joins every thread.
  void shutdown(double grace_s);

  size_t queue_depth() const;
  size_t running() const;
  const std::string& worker_bin() const { return worker_bin_; }

 private:
  void worker_loop();
  void janitor_loop();
  void run_job(const std::string& id);

  const Config& config_;
  std::string worker_bin_;
  JobStore& store_;
  Metrics& metrics_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::string> queue_;
  std::map<std::string, pid_t> running_;  // claimed jobs; pid 0 until forked
  std::set<std::string> cancel_requests_;
  bool draining_ = false;   // no new jobs start
  bool kill_all_ = false;   // running jobs are interrupted (shutdown)
  bool stopped_ = false;
  std::vector<std::thread> threads_;
  std::thread janitor_;
};

}  // namespace hocurve::server
