#include "server/job_store.hpp"
#include "server/json_text.hpp"

#include "server/log.hpp"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <sys/file.h>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>

namespace hocurve::server {
namespace fs = std::filesystem;

namespace {
nlohmann::json time_or_null(double t) { return t > 0 ? nlohmann::json(rfc3339(t)) : nlohmann::json(nullptr); }

/// Bytes of the regular files in folder `dir`.
std::uint64_t folder_bytes(const std::string& dir) {
  std::error_code ec;
  std::uint64_t bytes = 0;
  for (auto& f : fs::directory_iterator(dir, ec))
    if (f.is_regular_file(ec)) bytes += f.file_size(ec);
  return bytes;
}

void fsync_path(const std::string& path, int flags) {
  int fd = ::open(path.c_str(), flags);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}
}  // namespace

nlohmann::json job_view(const Job& j) {
  nlohmann::json v = {
      {"id", j.id},
      {"status", j.status},
      {"done", j.terminal()},
      {"progress", {{"stage", j.stage}, {"fraction", j.fraction}}},
      {"created", time_or_null(j.created)},
      {"started", time_or_null(j.started)},
      {"finished", time_or_null(j.finished)},
      {"expires", time_or_null(j.expires)},
      {"options", j.options},
      {"input", j.input},
      {"stats", j.stats.is_null() ? nlohmann::json(nullptr) : j.stats},
      {"error", j.error.is_null() ? nlohmann::json(nullptr) : j.error},
      {"attempts", j.attempts},
  };
  nlohmann::json links = {{"self", "/v1/jobs/" + j.id}};
  if (j.status == "succeeded") {
    links["result"] = "/v1/jobs/" + j.id + "/result";
    links["stats"] = "/v1/jobs/" + j.id + "/stats";
    v["result"] = {{"href", links["result"]}, {"bytes", j.result_bytes}};
  } else {
    v["result"] = nullptr;
  }
  v["links"] = links;
  return v;
}

nlohmann::json job_to_state(const Job& j) {
  return {{"id", j.id},         {"status", j.status},     {"stage", j.stage},
          {"fraction", j.fraction}, {"created", j.created}, {"started", j.started},
          {"finished", j.finished}, {"expires", j.expires}, {"options", j.options},
          {"input", j.input},   {"stats", j.stats},       {"error", j.error},
          {"result_bytes", j.result_bytes}, {"idempotency_key", j.idempotency_key},
          {"fingerprint", j.fingerprint}, {"attempts", j.attempts}, {"sync", j.sync}};
}

Job job_from_state(const nlohmann::json& s) {
  Job j;
  j.id = s.at("id").get<std::string>();
  j.status = s.value("status", "queued");
  j.stage = s.value("stage", "queued");
  j.fraction = s.value("fraction", 0.0);
  j.created = s.value("created", 0.0);
  j.started = s.value("started", 0.0);
  j.finished = s.value("finished", 0.0);
  j.expires = s.value("expires", 0.0);
  j.options = s.value("options", nlohmann::json::object());
  j.input = s.value("input", nlohmann::json::object());
  if (s.contains("stats")) j.stats = s["stats"];
  if (s.contains("error")) j.error = s["error"];
  j.result_bytes = s.value("result_bytes", std::uint64_t{0});
  j.idempotency_key = s.value("idempotency_key", "");
  j.fingerprint = s.value("fingerprint", "");
  j.attempts = s.value("attempts", 0);
  j.sync = s.value("sync", false);
  return j;
}

void write_file_atomic(const std::string& path, const std::string& text) {
  std::string tmp = path + ".tmp";
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + tmp);
  size_t off = 0;
  while (off < text.size()) {
    ssize_t n = ::write(fd, text.data() + off, text.size() - off);
    if (n <= 0) {
      ::close(fd);
      throw std::runtime_error("cannot write " + tmp);
    }
    off += (size_t)n;
  }
  ::fsync(fd);
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) throw std::runtime_error("cannot rename " + tmp);
  fsync_path(fs::path(path).parent_path().string(), O_RDONLY | O_DIRECTORY);
}

JobStore::JobStore(std::string data_dir) : data_dir_(std::move(data_dir)) {
  if (data_dir_.empty()) throw std::runtime_error("the data directory path is empty");
  fs::create_directories(fs::path(data_dir_) / "jobs");
  fs::create_directories(uploads_dir());
  // One daemon per data directory: a second one would rerun the first one's jobs and delete its
  // uploads. The lock goes with the process (also on kill -9).
  const std::string lock = lock_path();
  lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw std::runtime_error("cannot open " + lock + ": " + std::strerror(errno));
  // A daemon killed with -9 can leave the lock held for a moment by a worker it had just forked:
  // the child holds a copy of every descriptor until its exec closes this one, or until it dies
  // with its parent, which on a loaded machine takes a while. A restart waits up to two seconds
  // for that before it refuses (a restart right after kill -9 failed once in CI).
  constexpr int lock_wait_ms = 2000, lock_poll_ms = 50;
  for (int waited_ms = 0; ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0; waited_ms += lock_poll_ms) {
    const int err = errno;
    if (err != EWOULDBLOCK) {  // a file system without locks (some NFS mounts): run, unguarded
      log_warn("cannot lock the data directory; make sure no other hocurved uses it",
               {{"lock", lock}, {"error", std::strerror(err)}});
      return;
    }
    if (waited_ms >= lock_wait_ms) {
      ::close(lock_fd_);
      lock_fd_ = -1;
      throw std::runtime_error("another hocurved is using this data directory (" + lock + " is locked)");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(lock_poll_ms));
  }
  lock_held_ = true;
}

std::string JobStore::lock_path() const { return (fs::path(data_dir_) / "lock").string(); }

std::string JobStore::check_storage() {
  std::lock_guard<std::mutex> guard(storage_mutex_);
  std::string problem;
  std::error_code ec;
  struct stat held {}, now {};
  if (!fs::is_directory(data_dir_, ec))
    problem = "the data directory " + data_dir_ + " is gone";
  else if (lock_held_ && !(::fstat(lock_fd_, &held) == 0 && ::stat(lock_path().c_str(), &now) == 0 &&
                           held.st_dev == now.st_dev && held.st_ino == now.st_ino))
    problem = take_lock_again();
  if (problem != storage_problem_) {
    if (problem.empty()) log_info("the data directory is usable again", {{"data_dir", data_dir_}});
    else log_warn("the data directory is unusable", {{"data_dir", data_dir_}, {"why", problem}});
    storage_problem_ = problem;
  }
  return problem;
}

std::string JobStore::take_lock_again() {
  const std::string lock = lock_path();
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return "the lock file " + lock + " was removed and cannot be made again: " + std::strerror(errno);
  struct stat mine {}, now {};
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd);
    return err == EWOULDBLOCK ? "the lock file " + lock + " was replaced and another process (a second hocurved?) holds it"
                              : "cannot lock " + lock + " again: " + std::strerror(err);
  }
  if (::fstat(fd, &mine) != 0 || ::stat(lock.c_str(), &now) != 0 || mine.st_ino != now.st_ino || mine.st_dev != now.st_dev) {
    ::close(fd);  // replaced again meanwhile: the next check tries anew
    return "the lock file " + lock + " keeps changing";
  }
  ::close(lock_fd_);
  lock_fd_ = fd;
  std::error_code ec;
  fs::create_directories(fs::path(data_dir_) / "jobs", ec);
  fs::create_directories(uploads_dir(), ec);
  log_warn("the data directory's lock file was gone: taken again", {{"lock", lock}});
  return "";
}

JobStore::~JobStore() {
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

std::string JobStore::job_dir(const std::string& id) const { return (fs::path(data_dir_) / "jobs" / id).string(); }
std::string JobStore::uploads_dir() const { return (fs::path(data_dir_) / "uploads").string(); }

std::string JobStore::new_id() {
  // 12 hex digits of milliseconds, 4 of a per-process counter, 8 random: sortable and unguessable enough.
  using namespace std::chrono;
  auto ms = duration_cast<milliseconds>(system_clock::now().time_since_epoch()).count();
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  std::lock_guard<std::mutex> lock(mutex_);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%012llx%04llx%08llx", (unsigned long long)ms,
                (unsigned long long)(id_counter_++ & 0xffff), (unsigned long long)(rng() & 0xffffffffULL));
  return buf;
}

std::vector<Job> JobStore::load() {
  std::vector<Job> loaded;
  std::error_code ec;
  fs::remove_all(uploads_dir(), ec);
  fs::create_directories(uploads_dir());
  for (auto& entry : fs::directory_iterator(fs::path(data_dir_) / "jobs")) {
    if (!entry.is_directory()) continue;
    fs::path state = entry.path() / "state.json";
    try {
      std::ifstream in(state);
      if (!in) throw std::runtime_error("no state.json");
      Job j = job_from_state(nlohmann::json::parse(in));
      if (j.id != entry.path().filename().string()) throw std::runtime_error("id mismatch");
      loaded.push_back(j);
    } catch (const std::exception& e) {
      log_warn("removing incomplete job folder", {{"path", entry.path().string()}, {"why", e.what()}});
      fs::remove_all(entry.path(), ec);
    }
  }
  std::sort(loaded.begin(), loaded.end(), [](const Job& a, const Job& b) { return a.id < b.id; });
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& j : loaded) {
    remove_leftovers(j.id);
    jobs_[j.id] = j;
    if (!j.idempotency_key.empty()) idempotency_[j.idempotency_key] = j.id;
    counted_[j.id] = folder_bytes(job_dir(j.id));
    disk_bytes_ += counted_[j.id];
  }
  return loaded;
}

void JobStore::remove_leftovers(const std::string& id) const {
  std::error_code ec;
  std::vector<fs::path> tmp;
  for (auto& f : fs::directory_iterator(job_dir(id), ec))
    if (f.path().filename().string().find(".tmp") != std::string::npos) tmp.push_back(f.path());
  for (auto& f : tmp) fs::remove(f, ec);
}

void JobStore::persist(const Job& job) const {
  write_file_atomic(job_dir(job.id) + "/state.json", json_text(job_to_state(job), 2) + "\n");
}

void JobStore::persist_version(const Job& job, std::uint64_t v) {
  std::lock_guard<std::mutex> lock(persist_mutex_);
  std::uint64_t& w = written_[job.id];
  if (w >= v) return;
  try {
    persist(job);
    w = v;
  } catch (const std::exception& e) {
    if (get(job.id)) throw;  // removed meanwhile: nothing to keep
  }
}

void JobStore::insert(const Job& job) {
  persist(job);
  const std::uint64_t bytes = folder_bytes(job_dir(job.id));
  std::lock_guard<std::mutex> lock(mutex_);
  jobs_[job.id] = job;
  versions_[job.id] = 1;
  counted_[job.id] = bytes;
  disk_bytes_ += bytes;
  if (!job.idempotency_key.empty()) idempotency_[job.idempotency_key] = job.id;
  changed_.notify_all();
}

void JobStore::recount(const std::string& id) {
  const std::uint64_t bytes = folder_bytes(job_dir(id));
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = counted_.find(id);
  if (it == counted_.end()) return;  // removed meanwhile
  disk_bytes_ = disk_bytes_ - std::min(it->second, disk_bytes_) + bytes;
  it->second = bytes;
}

std::optional<Job> JobStore::get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second;
}

std::optional<Job> JobStore::update(const std::string& id, const std::function<void(Job&)>& fn, bool persist_it) {
  Job copy;
  std::uint64_t version = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return std::nullopt;
    fn(it->second);
    copy = it->second;
    version = ++versions_[id];
    changed_.notify_all();
  }
  if (persist_it) persist_version(copy, version);
  return copy;
}

bool JobStore::remove(const std::string& id, std::string* error) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return false;
    // The state file makes a job come back after a restart: it goes first, or the job stays.
    std::error_code ec;
    fs::remove(fs::path(job_dir(id)) / "state.json", ec);
    if (ec) {
      if (error) *error = "cannot delete the job's files: " + ec.message();
      return false;
    }
    if (!it->second.idempotency_key.empty()) idempotency_.erase(it->second.idempotency_key);
    jobs_.erase(it);
    versions_.erase(id);
    // The space is freed in the same step as the job leaves the list: a client that sees it gone
    // and uploads again must not meet the quota still holding it.
    disk_bytes_ -= std::min(counted_[id], disk_bytes_);
    counted_.erase(id);
    changed_.notify_all();
  }
  {
    std::lock_guard<std::mutex> lock(persist_mutex_);  // also waits for a write in progress
    written_.erase(id);
  }
  std::error_code ec;
  fs::remove_all(job_dir(id), ec);
  return true;
}

std::vector<Job> JobStore::list(size_t limit, const std::string& after, const std::string& status, bool& more) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Job> out;
  more = false;
  auto it = after.empty() ? jobs_.end() : jobs_.lower_bound(after);
  while (it != jobs_.begin()) {
    --it;
    const Job& j = it->second;
    if (j.sync || (!status.empty() && j.status != status)) continue;
    if (out.size() == limit) {
      more = true;
      break;
    }
    out.push_back(j);
  }
  return out;
}

std::vector<Job> JobStore::all() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Job> out;
  for (auto& [_, j] : jobs_) out.push_back(j);
  return out;
}

std::optional<Job> JobStore::find_idempotent(const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = idempotency_.find(key);
  if (it == idempotency_.end()) return std::nullopt;
  auto jt = jobs_.find(it->second);
  if (jt == jobs_.end()) return std::nullopt;
  return jt->second;
}

std::optional<Job> JobStore::wait_terminal(const std::string& id, double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return std::nullopt;
    if (it->second.terminal()) {
      // The state is changed in memory before it is saved: save it here if the updater has not
      // yet, so that what the caller reports (DELETE's "cancelled") survives a crash.
      const Job copy = it->second;
      const std::uint64_t version = versions_[id];
      lock.unlock();
      persist_version(copy, version);
      return copy;
    }
    if (changed_.wait_until(lock, deadline) == std::cv_status::timeout) {
      auto jt = jobs_.find(id);
      if (jt == jobs_.end()) return std::nullopt;
      return jt->second;
    }
  }
}

std::map<std::string, long long> JobStore::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, long long> c = {{"queued", 0}, {"running", 0}, {"succeeded", 0}, {"failed", 0}, {"cancelled", 0}};
  for (auto& [_, j] : jobs_) c[j.status]++;
  return c;
}

std::uint64_t JobStore::disk_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return disk_bytes_;
}

bool JobStore::reserve(std::uint64_t bytes, std::uint64_t quota) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (disk_bytes_ + reserved_ + bytes > quota) return false;
  reserved_ += bytes;
  return true;
}

void JobStore::release(std::uint64_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  reserved_ -= std::min(bytes, reserved_);
}

std::uint64_t JobStore::reserved_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reserved_;
}

}  // namespace hocurve::server
