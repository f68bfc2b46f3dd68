#include "server/config.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace hocurve::server {
namespace {

using Setter = std::function<void(Config&, const std::string&)>;

double to_number(const std::string& name, const std::string& v, double lo, double hi) {
  try {
    size_t pos = 0;
    double d = std::stod(v, &pos);
    if (pos != v.size() || !(d >= lo && d <= hi)) throw std::invalid_argument("range");
    return d;
  } catch (...) {
    std::ostringstream os;
    os << "--" << name << ": expected a number in [" << lo << ", " << hi << "], got '" << v << "'";
    throw std::runtime_error(os.str());
  }
}

const std::map<std::string, Setter>& setters() {
  static const std::map<std::string, Setter> s = {
      {"host", [](Config& c, const std::string& v) { c.host = v; }},
      {"port", [](Config& c, const std::string& v) { c.port = (int)to_number("port", v, 0, 65535); }},
      {"data-dir", [](Config& c, const std::string& v) { c.data_dir = v; }},
      {"workers", [](Config& c, const std::string& v) { c.workers = (int)to_number("workers", v, 1, 256); }},
      {"http-threads", [](Config& c, const std::string& v) { c.http_threads = (int)to_number("http-threads", v, 2, 1024); }},
      {"client-timeout", [](Config& c, const std::string& v) { c.client_timeout = to_number("client-timeout", v, 0.1, 3600); }},
      {"job-threads", [](Config& c, const std::string& v) { c.job_threads = (int)to_number("job-threads", v, 1, 256); }},
      {"max-upload-mb", [](Config& c, const std::string& v) { c.max_upload_mb = to_number("max-upload-mb", v, 0.001, 1e6); }},
      {"max-sync-mb", [](Config& c, const std::string& v) { c.max_sync_mb = to_number("max-sync-mb", v, 0.001, 1e6); }},
      {"max-queue", [](Config& c, const std::string& v) { c.max_queue = (int)to_number("max-queue", v, 1, 1e6); }},
      {"job-timeout", [](Config& c, const std::string& v) { c.job_timeout = to_number("job-timeout", v, 0.1, 1e7); }},
      {"job-memory-mb", [](Config& c, const std::string& v) { c.job_memory_mb = to_number("job-memory-mb", v, 16, 1e8); }},
      {"retention", [](Config& c, const std::string& v) { c.retention = to_number("retention", v, 0, 1e9); }},
      {"max-disk-mb", [](Config& c, const std::string& v) { c.max_disk_mb = to_number("max-disk-mb", v, 0.001, 1e9); }},
      {"shutdown-grace", [](Config& c, const std::string& v) { c.shutdown_grace = to_number("shutdown-grace", v, 0, 3600); }},
      {"max-attempts", [](Config& c, const std::string& v) { c.max_attempts = (int)to_number("max-attempts", v, 1, 100); }},
      {"token-file", [](Config& c, const std::string& v) { c.token_file = v; }},
      {"hocurve-bin", [](Config& c, const std::string& v) { c.hocurve_bin = v; }},
  };
  return s;
}

std::string env_name(const std::string& flag) {
  std::string e = "HOCURVE_";
  for (char ch : flag) e += ch == '-' ? '_' : (char)std::toupper((unsigned char)ch);
  return e;
}

}  // namespace

std::string config_usage() {
  std::ostringstream os;
  os << "usage: hocurved [--flag value]...\n"
        "Every flag may also be given as an environment variable (HOCURVE_<FLAG>, dashes as underscores;\n"
        "the worker program also as HOCURVE_BIN). Flags:\n";
  for (auto& [name, _] : setters()) os << "  --" << name << "   (" << env_name(name) << ")\n";
  return os.str();
}

bool parse_config(int argc, char** argv, Config& c) {
  for (auto& [name, set] : setters())
    if (const char* v = std::getenv(env_name(name).c_str()); v && *v) set(c, v);
  if (const char* v = std::getenv("HOCURVE_BIN"); v && *v && c.hocurve_bin.empty()) c.hocurve_bin = v;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << config_usage();
      return false;
    }
    if (a.rfind("--", 0) != 0) throw std::runtime_error("unexpected argument '" + a + "'");
    std::string name = a.substr(2), value;
    if (auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    } else {
      if (i + 1 >= argc) throw std::runtime_error("--" + name + " needs a value");
      value = argv[++i];
    }
    auto it = setters().find(name);
    if (it == setters().end()) throw std::runtime_error("unknown flag --" + name + " (see --help)");
    it->second(c, value);
  }
  if (!c.token_file.empty()) {
    std::ifstream in(c.token_file);
    if (!in) throw std::runtime_error("--token-file: cannot read '" + c.token_file + "'");
    std::getline(in, c.token);
    while (!c.token.empty() && std::isspace((unsigned char)c.token.back())) c.token.pop_back();
    if (c.token.empty()) throw std::runtime_error("--token-file: '" + c.token_file + "' is empty");
  }
  return true;
}

std::string locate_worker(const std::string& configured, const char* argv0) {
  namespace fs = std::filesystem;
  if (!configured.empty()) return configured;
  std::error_code ec;
  fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) self = fs::absolute(argv0, ec);
  fs::path candidate = self.parent_path() / "hocurve";
  return candidate.string();
}

}  // namespace hocurve::server
