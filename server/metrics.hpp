// Prometheus text exposition (version 0.0.4), hand-written: counters, gauges and fixed-bucket histograms.
#pragma once
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

namespace hocurve::server {

/// GET, HEAD, POST, PUT, PATCH, DELETE or OPTIONS.
bool known_http_method(const std::string& method);

/// Fixed-bucket histogram; observe() is thread-safe.
class Histogram {
 public:
  explicit Histogram(std::vector<double> upper_bounds);
  void observe(double value);
  /// Appends `name_bucket{labels,le=..}`, `name_sum`, `name_count` lines. `labels` is "" or `k="v"`.
  void render(std::string& out, const std::string& name, const std::string& labels) const;

 private:
  std::vector<double> bounds_;
  mutable std::mutex mutex_;
  std::vector<std::uint64_t> counts_;  // per bucket, not cumulative; last = +Inf
  double sum_ = 0;
  std::uint64_t count_ = 0;
};

/// Gauges sampled at scrape time.
struct GaugeSnapshot {
  std::map<std::string, long long> jobs_by_state;
  long long queue_depth = 0, running = 0, queue_capacity = 0, workers = 0;
  std::uint64_t disk_bytes = 0, disk_quota_bytes = 0;
  bool ready = true;
};

class Metrics {
 public:
  Metrics();
  /// `method` is counted as "other" unless known_http_method: a bounded label set.
  void count_request(const std::string& method, const std::string& route, int status, double seconds);
  void job_submitted(const std::string& mode);
  void job_finished(const std::string& state, double seconds);
  std::atomic<std::uint64_t> upload_bytes{0}, download_bytes{0}, rejected_queue_full{0};
  /// The whole exposition, ending with '\n'.
  std::string render(const GaugeSnapshot& gauges, const std::string& version) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, std::uint64_t> submitted_, finished_;
  Histogram request_seconds_;
  Histogram job_seconds_;
  double start_time_;
};

/// Escapes a label value (\\, \", \n).
std::string escape_label(const std::string& v);

}  // namespace hocurve::server
