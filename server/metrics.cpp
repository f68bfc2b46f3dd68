#include "server/metrics.hpp"

#include "server/log.hpp"

#include <cstdio>
#include <set>
#include <sstream>

namespace hocurve::server {
namespace {
std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
void family(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}
}  // namespace

std::string escape_label(const std::string& v) {
  std::string o;
  for (char c : v) {
    if (c == '\\') o += "\\\\";
    else if (c == '"') o += "\\\"";
    else if (c == '\n') o += "\\n";
    else o += c;
  }
  return o;
}

Histogram::Histogram(std::vector<double> b) : bounds_(std::move(b)), counts_(bounds_.size() + 1, 0) {}

void Histogram::observe(double v) {
  std::lock_guard<std::mutex> lock(mutex_);
  size_t i = 0;
  while (i < bounds_.size() && v > bounds_[i]) ++i;
  counts_[i]++;
  sum_ += v;
  count_++;
}

void Histogram::render(std::string& out, const std::string& name, const std::string& labels) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string sep = labels.empty() ? "" : labels + ",";
  std::uint64_t cum = 0;
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    cum += counts_[i];
    std::string le = i < bounds_.size() ? num(bounds_[i]) : "+Inf";
    out += name + "_bucket{" + sep + "le=\"" + le + "\"} " + std::to_string(cum) + "\n";
  }
  std::string lb = labels.empty() ? "" : "{" + labels + "}";
  out += name + "_sum" + lb + " " + num(sum_) + "\n";
  out += name + "_count" + lb + " " + std::to_string(count_) + "\n";
}

Metrics::Metrics()
    : request_seconds_({0.001, 0.005, 0.01, 0.05, 0.1, 0.5, 1, 5}),
      job_seconds_({0.1, 0.5, 1, 2, 5, 10, 30, 60, 300, 1800}),
      start_time_(now_seconds()) {}

bool known_http_method(const std::string& method) {
  static const std::set<std::string> known = {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"};
  return known.count(method) > 0;
}

void Metrics::count_request(const std::string& method, const std::string& route, int status, double seconds) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requests_[{known_http_method(method) ? method : "other", route, status}]++;
  }
  request_seconds_.observe(seconds);
}

void Metrics::job_submitted(const std::string& mode) {
  std::lock_guard<std::mutex> lock(mutex_);
  submitted_[mode]++;
}

void Metrics::job_finished(const std::string& state, double seconds) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_[state]++;
  }
  if (state == "succeeded" || state == "failed") job_seconds_.observe(seconds);
}

std::string Metrics::render(const GaugeSnapshot& g, const std::string& version) const {
  std::string out;
  family(out, "hocurve_build_info", "gauge", "Build information.");
  out += "hocurve_build_info{version=\"" + escape_label(version) + "\",api_version=\"1\"} 1\n";
  family(out, "process_start_time_seconds", "gauge", "Start time of the process since the epoch in seconds.");
  out += "process_start_time_seconds " + num(start_time_) + "\n";
  family(out, "hocurve_ready", "gauge", "1 when the server accepts jobs, 0 while draining.");
  out += std::string("hocurve_ready ") + (g.ready ? "1" : "0") + "\n";
  family(out, "hocurve_jobs", "gauge", "Jobs in the store by state.");
  for (auto& [state, n] : g.jobs_by_state)
    out += "hocurve_jobs{state=\"" + escape_label(state) + "\"} " + std::to_string(n) + "\n";
  family(out, "hocurve_jobs_queued", "gauge", "Jobs waiting for a worker (queue depth).");
  out += "hocurve_jobs_queued " + std::to_string(g.queue_depth) + "\n";
  family(out, "hocurve_jobs_running", "gauge", "Jobs running in a worker process.");
  out += "hocurve_jobs_running " + std::to_string(g.running) + "\n";
  family(out, "hocurve_queue_capacity", "gauge", "Maximum queued jobs before 429.");
  out += "hocurve_queue_capacity " + std::to_string(g.queue_capacity) + "\n";
  family(out, "hocurve_workers", "gauge", "Concurrent worker processes allowed.");
  out += "hocurve_workers " + std::to_string(g.workers) + "\n";
  family(out, "hocurve_disk_bytes", "gauge", "Bytes held in the data directory by jobs.");
  out += "hocurve_disk_bytes " + std::to_string(g.disk_bytes) + "\n";
  family(out, "hocurve_disk_quota_bytes", "gauge", "Disk quota of the data directory.");
  out += "hocurve_disk_quota_bytes " + std::to_string(g.disk_quota_bytes) + "\n";
  family(out, "hocurve_upload_bytes_total", "counter", "Mesh bytes received.");
  out += "hocurve_upload_bytes_total " + std::to_string(upload_bytes.load()) + "\n";
  family(out, "hocurve_download_bytes_total", "counter", "Result bytes sent.");
  out += "hocurve_download_bytes_total " + std::to_string(download_bytes.load()) + "\n";
  family(out, "hocurve_queue_full_total", "counter", "Submissions refused with 429 because the queue was full.");
  out += "hocurve_queue_full_total " + std::to_string(rejected_queue_full.load()) + "\n";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    family(out, "hocurve_jobs_submitted_total", "counter", "Jobs accepted, by mode.");
    for (auto& [mode, n] : submitted_)
      out += "hocurve_jobs_submitted_total{mode=\"" + escape_label(mode) + "\"} " + std::to_string(n) + "\n";
    family(out, "hocurve_jobs_finished_total", "counter", "Jobs that reached a terminal state, by state.");
    for (auto& [state, n] : finished_)
      out += "hocurve_jobs_finished_total{state=\"" + escape_label(state) + "\"} " + std::to_string(n) + "\n";
    family(out, "hocurve_http_requests_total", "counter", "HTTP requests by method, route template and status.");
    for (auto& [key, n] : requests_) {
      auto& [method, route, code] = key;
      out += "hocurve_http_requests_total{method=\"" + escape_label(method) + "\",route=\"" + escape_label(route) +
             "\",code=\"" + std::to_string(code) + "\"} " + std::to_string(n) + "\n";
    }
  }
  family(out, "hocurve_job_duration_seconds", "histogram", "Wall time of finished jobs in the worker.");
  job_seconds_.render(out, "hocurve_job_duration_seconds", "");
  family(out, "hocurve_http_request_duration_seconds", "histogram", "HTTP request latency.");
  request_seconds_.render(out, "hocurve_http_request_duration_seconds", "");
  return out;
}

}  // namespace hocurve::server
