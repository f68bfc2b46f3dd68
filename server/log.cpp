#include "server/log.hpp"
#include "server/json_text.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <mutex>

namespace hocurve::server {

double now_seconds() {
  using namespace std::chrono;
  return duration<double>(system_clock::now().time_since_epoch()).count();
}

std::string rfc3339(double t) {
  if (t <= 0) return "";
  std::time_t secs = static_cast<std::time_t>(std::floor(t));
  int ms = static_cast<int>((t - std::floor(t)) * 1000.0);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, ms);
  return buf;
}

void log_json(const std::string& level, const std::string& msg, nlohmann::json fields) {
  // One mutex so concurrent records never interleave within a line.
  static std::mutex mutex;
  nlohmann::json rec = nlohmann::json::object();
  rec["ts"] = rfc3339(now_seconds());
  rec["level"] = level;
  rec["msg"] = msg;
  if (fields.is_object())
    for (auto& [k, v] : fields.items()) rec[k] = v;
  std::string line = json_text(rec);
  line += '\n';
  std::lock_guard<std::mutex> lock(mutex);
  std::fwrite(line.data(), 1, line.size(), stdout);
  std::fflush(stdout);
}

}  // namespace hocurve::server
