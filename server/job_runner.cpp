#include "server/job_runner.hpp"

#include "server/job_options.hpp"
#include "server/log.hpp"
#include "server/problem.hpp"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <functional>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

namespace hocurve::server {
namespace fs = std::filesystem;

namespace {

/// s without any occurrence of the job folder `dir` (ending in '/'): the worker names its files by
/// path; clients see them relative to the job folder, and server paths stay private.
std::string without_dir(std::string s, const std::string& dir) {
  for (size_t at; (at = s.find(dir)) != std::string::npos;) s.erase(at, dir.size());
  return s;
}

/// Last non-empty line of a (small) text file, at most 500 characters.
std::string last_line(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (!line.empty()) last = line;
  }
  // ".../jobs/<id>/input.stl: facet 7" -> "input.stl: facet 7".
  last = without_dir(last, fs::path(path).parent_path().string() + "/");
  if (last.size() > 500) last = last.substr(0, 500) + "...";
  return last;
}

/// True when a worker that died of a signal says it ran out of memory first: under RLIMIT_AS an
/// allocation or a thread's stack fails, and the C++ runtime aborts on the uncaught exception.
bool ran_out_of_memory(int sig, const std::string& log_path) {
  if (sig != SIGABRT && sig != SIGSEGV && sig != SIGBUS && sig != SIGKILL) return false;
  std::ifstream in(log_path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(std::max<std::streamoff>(0, size - 4096));
  const std::string tail((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* sign : {"bad_alloc", "Cannot allocate memory", "pthread_create has failed", "out of memory",
                           "failed to map segment"})
    if (tail.find(sign) != std::string::npos) return true;
  return false;
}

/// without_dir of every string in j (the worker's stats name its input and output by path).
void strip_dir(nlohmann::json& j, const std::string& dir) {
  if (j.is_string()) {
    j = without_dir(j.get<std::string>(), dir);
  } else if (j.is_structured()) {
    for (auto& v : j) strip_dir(v, dir);
  }
}

std::string signal_name(int sig) {
  const char* d = strsignal(sig);
  return "signal " + std::to_string(sig) + (d ? std::string(" (") + d + ")" : "");
}

/// Runs a short helper command (e.g. `hocurve info IN --json`) with the job's limits and a
/// wall-clock timeout, stopped early when stop() says so; returns its wait status (-1 on timeout,
/// stop or spawn failure) and stdout (≤ 1 MiB).
std::pair<int, std::string> run_capture(const std::vector<std::string>& args, double timeout_s, rlim_t mem,
                                        const std::string& stderr_path, const std::function<bool()>& stop) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  int pipefd[2];
  if (::pipe2(pipefd, O_CLOEXEC) != 0) return {-1, ""};
  int errfd = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const pid_t parent = ::getpid();
  pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGPIPE, SIG_DFL);
    ::dup2(pipefd[1], 1);
    if (errfd >= 0) ::dup2(errfd, 2);
    ::syscall(SYS_close_range, 3u, ~0u, 0u);
    struct rlimit rl = {mem, mem};
    ::setrlimit(RLIMIT_AS, &rl);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(pipefd[1]);
  if (errfd >= 0) ::close(errfd);
  if (pid < 0) {
    ::close(pipefd[0]);
    return {-1, ""};
  }
  ::setpgid(pid, pid);
  std::string out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool timed_out = false;
  for (;;) {
    struct pollfd p = {pipefd[0], POLLIN, 0};
    if (std::chrono::steady_clock::now() > deadline || stop()) {
      timed_out = true;
      ::kill(-pid, SIGKILL);
      break;
    }
    if (::poll(&p, 1, 100) <= 0) continue;
    char buf[8192];
    ssize_t n = ::read(pipefd[0], buf, sizeof buf);
    if (n <= 0) break;
    if (out.size() < (1u << 20)) out.append(buf, (size_t)n);
  }
  ::close(pipefd[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return {timed_out ? -1 : status, out};
}

struct ProcessOutcome {
  enum Kind { kExited, kSignaled, kTimeout, kCancelled, kInterrupted, kSpawnFailed } kind = kExited;
  int code = 0;  // exit code or signal
  std::string spawn_error;
};

}  // namespace

JobRunner::JobRunner(const Config& config, std::string worker_bin, JobStore& store, Metrics& metrics)
    : config_(config), worker_bin_(std::move(worker_bin)), store_(store), metrics_(metrics) {}

JobRunner::~JobRunner() {
  if (!stopped_) shutdown(0);
}

void JobRunner::start() {
  for (int i = 0; i < config_.workers; ++i) threads_.emplace_back([this] { worker_loop(); });
  janitor_ = std::thread([this] { janitor_loop(); });
}

bool JobRunner::enqueue(const std::string& id, bool force, bool front) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!force && (int)queue_.size() >= config_.max_queue) return false;
  if (front) queue_.push_front(id);
  else queue_.push_back(id);
  cv_.notify_all();  // the janitor waits on cv_ too: notify_one could wake only it
  return true;
}

void JobRunner::cancel(const std::string& id) {
  bool was_queued = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = std::find(queue_.begin(), queue_.end(), id);
    if (it != queue_.end()) {
      queue_.erase(it);
      was_queued = true;
    } else if (auto rt = running_.find(id); rt != running_.end()) {
      cancel_requests_.insert(id);
      if (rt->second > 0) ::kill(-rt->second, SIGKILL);
    }
  }
  if (was_queued) {
    double now = now_seconds();
    store_.update(id, [&](Job& j) {
      if (j.terminal()) return;
      j.status = "cancelled";
      j.stage = "cancelled";
      j.finished = now;
      j.expires = now + std::min(config_.retention, 60.0);
      j.error = make_problem(409, "cancelled", "job " + id + " was cancelled before it started");
    });
    metrics_.job_finished("cancelled", 0);
    log_info("job cancelled", {{"job_id", id}, {"was", "queued"}});
  }
}

size_t JobRunner::queue_depth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

size_t JobRunner::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_.size();
}

void JobRunner::shutdown(double grace_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (stopped_) return;
  draining_ = true;
  cv_.notify_all();
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
  cv_.wait_until(lock, deadline, [&] { return running_.empty(); });
  kill_all_ = true;
  for (auto& [id, pid] : running_)
    if (pid > 0) ::kill(-pid, SIGKILL);
  stopped_ = true;
  cv_.notify_all();
  lock.unlock();
  for (auto& t : threads_) t.join();
  threads_.clear();
  if (janitor_.joinable()) janitor_.join();
}

void JobRunner::worker_loop() {
  for (;;) {
    std::string id;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return stopped_ || draining_ || !queue_.empty(); });
      if (stopped_ || draining_) return;
      id = queue_.front();
      queue_.pop_front();
      running_[id] = 0;
    }
    try {
      run_job(id);
    } catch (const std::exception& e) {
      log_error("job runner error", {{"job_id", id}, {"error", e.what()}});
      try {  // a job left "running" would run again after every restart
        store_.update(id, [&](Job& j) {
          if (j.terminal()) return;
          j.status = j.stage = "failed";
          j.finished = now_seconds();
          j.expires = j.finished + config_.retention;
          j.error = make_problem(500, "internal", std::string("job runner error: ") + e.what());
        });
      } catch (const std::exception& e2) {
        log_error("job state not saved", {{"job_id", id}, {"error", e2.what()}});
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    running_.erase(id);
    cancel_requests_.erase(id);
    cv_.notify_all();
  }
}

void JobRunner::janitor_loop() {
  // Deletes jobs whose retention ended and checks the data directory's lock. Wakes up at least every second so shutdown stays prompt.
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopped_) {
    cv_.wait_for(lock, std::chrono::seconds(1));
    if (stopped_) break;
    lock.unlock();
    store_.check_storage();  // takes the data directory's lock again if it was deleted
    double now = now_seconds();
    for (const Job& j : store_.all())
      if (j.terminal() && j.expires > 0 && j.expires <= now) {
        store_.remove(j.id);
        log_info("job expired", {{"job_id", j.id}});
      }
    lock.lock();
  }
}

void JobRunner::run_job(const std::string& id) {
  const double t0 = now_seconds();
  // One time budget for the whole job: the info step's time counts against it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(config_.job_timeout);
  auto claimed = store_.update(id, [&](Job& j) {
    if (j.terminal()) return;
    j.status = "running";
    j.stage = "starting";
    j.fraction = 0;
    j.started = t0;
    j.attempts += 1;
  });
  if (!claimed || claimed->terminal()) return;
  const Job job = *claimed;
  const std::string dir = store_.job_dir(id);
  const std::string input = dir + "/" + job.input.value("filename", "input");
  const std::string part = dir + "/result.part.msh", result = dir + "/result.msh";
  const std::string stats = dir + "/stats.json", logfile = dir + "/worker.log";
  std::error_code ec;
  fs::remove(part, ec);

  auto finish = [&](const std::string& status, nlohmann::json error) {
    double now = now_seconds();
    std::uint64_t bytes = 0;
    nlohmann::json stats_json;
    if (status == "succeeded") {
      bytes = fs::file_size(result, ec);
      std::ifstream in(stats);
      if (in) stats_json = nlohmann::json::parse(in, nullptr, false);
      if (stats_json.is_discarded()) stats_json = nullptr;
      strip_dir(stats_json, dir + "/");
    } else {
      fs::remove(part, ec);
    }
    store_.update(id, [&](Job& j) {
      j.status = status;
      j.stage = status;
      if (status == "succeeded") j.fraction = 1;
      j.finished = now;
      j.expires = now + (status == "cancelled" ? std::min(config_.retention, 60.0) : config_.retention);
      j.error = error;
      j.stats = stats_json;
      j.result_bytes = bytes;
    });
    store_.recount(id);  // the result, stats and log now count against the quota
    metrics_.job_finished(status, now - t0);
    nlohmann::json f = {{"job_id", id}, {"status", status}, {"duration_ms", (long long)((now - t0) * 1000)}};
    if (!error.is_null()) f["error_code"] = error.value("code", "");
    log_info("job finished", f);
  };

  // A mesh whose reading or curving runs out of the job's memory (RLIMIT_AS): too large for this
  // server, e.g. a gzip bomb; the client's to fix, not an internal error.
  auto too_big = [&](const std::string& worker_said) {
    return make_problem(413, "payload-too-large",
                        "the mesh needs more memory than the job limit of " +
                            std::to_string((long long)config_.job_memory_mb) +
                            " MiB (a very large mesh, or a gzip file that inflates to one)" +
                            (worker_said.empty() ? "" : ": " + worker_said));
  };

  if (job.attempts > config_.max_attempts) {
    store_.update(id, [](Job& j) { j.attempts -= 1; });  // this claim ran nothing
    finish("failed", make_problem(500, "worker-crashed",
                                  "job was interrupted " + std::to_string(job.attempts - 1) +
                                      " times (daemon restarts); giving up"));
    return;
  }

  // Input counts from `hocurve info --json` (cheap); a mesh it refuses fails the job right here.
  const rlim_t mem_limit = (rlim_t)(config_.job_memory_mb * 1024 * 1024);
  {
    auto stop = [&] {  // a cancel or a shutdown stops the info step too (the main run then sees why)
      std::lock_guard<std::mutex> lock(mutex_);
      return cancel_requests_.count(id) > 0 || kill_all_;
    };
    auto [st, out] = run_capture({worker_bin_, "info", input, "--json"}, std::min(config_.job_timeout, 60.0),
                                 mem_limit, logfile, stop);
    if (st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 0) {
      auto info = nlohmann::json::parse(out, nullptr, false);
      if (info.is_object()) {
        nlohmann::json counts = nlohmann::json::object();
        for (const char* k : {"vertices", "faces", "edges", "euler_characteristic", "format", "gzip"})
          if (info.contains(k)) counts[k] = info[k];
        store_.update(id, [&](Job& j) { j.input["counts"] = counts; });
      }
    } else if (st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 3) {
      const std::string why = last_line(logfile);
      finish("failed", make_problem(422, "invalid-mesh", why.empty() ? "mesh refused" : why));
      return;
    } else if (st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 5) {
      finish("failed", too_big(last_line(logfile)));
      return;
    } else if (st >= 0 && WIFSIGNALED(st) && ran_out_of_memory(WTERMSIG(st), logfile)) {
      finish("failed", too_big(last_line(logfile)));
      return;
    } else if (st >= 0 && WIFSIGNALED(st) && !stop()) {
      // The same input would crash the main run too, with no counts to show for it.
      finish("failed", make_problem(500, "worker-crashed",
                                    "the input check (hocurve info) was killed by " + signal_name(WTERMSIG(st)) +
                                        (last_line(logfile).empty() ? "" : ": " + last_line(logfile))));
      return;
    }
    // Anything else (an older worker without `info`, a timeout, a cancel): the main run reports it.
  }

  std::vector<std::string> args = worker_argv(worker_bin_, job.options, input, part, stats, config_.job_threads);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  log_info("job started", {{"job_id", id}, {"attempt", job.attempts}, {"argv", args}});

  ProcessOutcome outcome;
  int pipefd[2];
  if (::pipe2(pipefd, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  int logfd = ::open(logfile.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const rlim_t mem = (rlim_t)(config_.job_memory_mb * 1024 * 1024);
  const rlim_t cpu = (rlim_t)(config_.job_timeout * std::max(1, config_.job_threads) + 5);
  const pid_t parent = ::getpid();

  pid_t pid;
  {
    // Fork under the lock so that cancel() sees either no pid or the real one.
    std::lock_guard<std::mutex> lock(mutex_);
    if (cancel_requests_.count(id) || kill_all_) {
      pid = -1;
    } else {
      pid = ::fork();
      if (pid == 0) {
        // Child: only async-signal-safe calls until exec.
        ::setpgid(0, 0);
        ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed daemon takes its workers along
        if (::getppid() != parent) ::_exit(126);
        sigset_t none;
        sigemptyset(&none);
        ::sigprocmask(SIG_SETMASK, &none, nullptr);
        ::signal(SIGPIPE, SIG_DFL);
        ::dup2(pipefd[1], 1);
        if (logfd >= 0) ::dup2(logfd, 2);
        int devnull = ::open("/dev/null", O_RDONLY);
        if (devnull >= 0) ::dup2(devnull, 0);
        ::syscall(SYS_close_range, 3u, ~0u, 0u);
        struct rlimit rl_mem = {mem, mem};
        ::setrlimit(RLIMIT_AS, &rl_mem);
        struct rlimit rl_cpu = {cpu, cpu + 5};
        ::setrlimit(RLIMIT_CPU, &rl_cpu);
        ::execv(argv[0], argv.data());
        const char msg[] = "hocurved: cannot execute the worker program\n";
        (void)!::write(2, msg, sizeof msg - 1);
        ::_exit(127);
      }
      if (pid > 0) {
        ::setpgid(pid, pid);
        running_[id] = pid;
      }
    }
  }
  ::close(pipefd[1]);
  if (logfd >= 0) ::close(logfd);
  if (pid < 0) {
    ::close(pipefd[0]);
    if (kill_all_) {
      store_.update(id, [&](Job& j) { j.status = "queued"; j.stage = "queued"; j.attempts -= 1; });
      return;
    }
    finish("cancelled", make_problem(409, "cancelled", "job " + id + " was cancelled"));
    return;
  }

  std::string buffer;
  bool eof = false, killed = false;
  int status = 0;
  auto handle_line = [&](const std::string& line) {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (!j.is_object() || !j.contains("fraction")) return;
    std::string stage = j.value("stage", "");
    double fraction = j["fraction"].is_number() ? j["fraction"].get<double>() : 0.0;
    fraction = std::clamp(fraction, 0.0, 1.0);
    store_.update(id, [&](Job& jj) {
      jj.stage = stage.empty() ? jj.stage : stage.substr(0, 64);
      jj.fraction = std::max(jj.fraction, fraction);  // progress bars never go backwards
    }, /*persist=*/false);
  };
  for (;;) {
    // Why killed: cancel request, shutdown, or timeout. The first reason wins.
    if (!killed) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (cancel_requests_.count(id)) outcome.kind = ProcessOutcome::kCancelled, killed = true;
      else if (kill_all_) outcome.kind = ProcessOutcome::kInterrupted, killed = true;
      else if (std::chrono::steady_clock::now() > deadline) outcome.kind = ProcessOutcome::kTimeout, killed = true;
      if (killed) ::kill(-pid, SIGKILL);
    }
    if (!eof) {
      struct pollfd p = {pipefd[0], POLLIN, 0};
      int r = ::poll(&p, 1, 100);
      if (r > 0) {
        char buf[4096];
        ssize_t n = ::read(pipefd[0], buf, sizeof buf);
        if (n <= 0) {
          eof = true;
        } else {
          buffer.append(buf, (size_t)n);
          size_t nl;
          while ((nl = buffer.find('\n')) != std::string::npos) {
            handle_line(buffer.substr(0, nl));
            buffer.erase(0, nl + 1);
          }
          if (buffer.size() > 65536) buffer.clear();  // a runaway line is not progress
        }
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    pid_t w = ::waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
  }
  ::close(pipefd[0]);
  ::kill(-pid, SIGKILL);  // stray grandchildren of the worker, if any
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running_[id] = 0;
  }

  if (!killed) {
    // cancel() and shutdown() kill the process group themselves; the loop may see the exit first.
    std::lock_guard<std::mutex> lock(mutex_);
    if (cancel_requests_.count(id)) outcome.kind = ProcessOutcome::kCancelled, killed = true;
    else if (kill_all_) outcome.kind = ProcessOutcome::kInterrupted, killed = true;
  }
  if (!killed) {
    if (WIFEXITED(status)) outcome = {ProcessOutcome::kExited, WEXITSTATUS(status), ""};
    else if (WIFSIGNALED(status)) outcome = {ProcessOutcome::kSignaled, WTERMSIG(status), ""};
  }
  store_.remove_leftovers(id);
  const std::string err_line = last_line(logfile);
  const std::string because = err_line.empty() ? "" : ": " + err_line;
  switch (outcome.kind) {
    case ProcessOutcome::kCancelled:
      finish("cancelled", make_problem(409, "cancelled", "job " + id + " was cancelled while running"));
      return;
    case ProcessOutcome::kInterrupted:
      // Shutdown: the job runs again after the restart.
      store_.update(id, [&](Job& j) {
        j.status = "queued";
        j.stage = "queued";
        j.fraction = 0;
        j.attempts -= 1;
      });
      log_info("job interrupted by shutdown; left queued", {{"job_id", id}});
      return;
    case ProcessOutcome::kTimeout:
      finish("failed", make_problem(504, "timeout",
                                    "job exceeded the time limit of " + std::to_string((int)config_.job_timeout) + " s"));
      return;
    case ProcessOutcome::kSignaled: {
      if (ran_out_of_memory(outcome.code, logfile)) {
        finish("failed", too_big(err_line));
        return;
      }
      std::string why = "worker process was killed by " + signal_name(outcome.code);
      if (outcome.code == SIGKILL || outcome.code == SIGXCPU)
        why += " (memory limit " + std::to_string((long long)config_.job_memory_mb) + " MiB or CPU limit?)";
      finish("failed", make_problem(500, "worker-crashed", why + because));
      return;
    }
    default:
      break;
  }
  switch (outcome.code) {
    case 0: {
      bool ok = fs::exists(part, ec);
      // The quota is checked on submission, when the result's size is unknown; a result that does
      // not fit is dropped here, so that disk use stays within the quota and one result.
      const std::uint64_t size = ok ? fs::file_size(part, ec) : 0;
      const auto quota = (std::uint64_t)(config_.max_disk_mb * 1048576);
      if (ok && store_.disk_bytes() + store_.reserved_bytes() + size > quota) {
        fs::remove(part, ec);
        finish("failed", make_problem(507, "quota-exceeded",
                                      "the result (" + std::to_string(size / 1024) +
                                          " KiB) does not fit in the data directory quota (" +
                                          std::to_string((long long)(quota / 1024)) + " KiB, " +
                                          std::to_string((long long)(store_.disk_bytes() / 1024)) + " KiB used)"));
        return;
      }
      if (ok) {
        fs::rename(part, result, ec);
        ok = !ec;
      }
      if (ok) finish("succeeded", nullptr);
      else finish("failed", make_problem(500, "internal", "worker exited 0 but wrote no result" + because));
      return;
    }
    case 2:
      finish("failed", make_problem(400, "invalid-options", "worker refused the options" + because));
      return;
    case 3:
      finish("failed", make_problem(422, "invalid-mesh", err_line.empty() ? "mesh refused" : err_line));
      return;
    case 5:
      finish("failed", too_big(err_line));
      return;
    case 127:
      finish("failed", make_problem(500, "internal", "cannot execute worker '" + worker_bin_ + "'"));
      return;
    default:
      if (err_line.find("No space left on device") != std::string::npos) {
        finish("failed", make_problem(507, "storage-full", "the data directory's disk is full" + because));
        return;
      }
      finish("failed", make_problem(500, "internal",
                                    "worker failed with exit code " + std::to_string(outcome.code) + because));
      return;
  }
}

}  // namespace hocurve::server
