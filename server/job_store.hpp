// Durable job store: one folder per job under <data-dir>/jobs/<id>/ holding the input, state.json
// (written atomically: write, fsync, rename), the result and the worker's stderr. The in-memory
// index mirrors state.json and is rebuilt from disk at start-up.
#pragma once
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hocurve::server {

/// One job. Times are seconds since the epoch (0 = not yet).
struct Job {
  std::string id;
  std::string status = "queued";  ///< queued | running | succeeded | failed | cancelled
  std::string stage = "queued";
  double fraction = 0;
  double created = 0, started = 0, finished = 0, expires = 0;
  nlohmann::json options = nlohmann::json::object();
  nlohmann::json input = nlohmann::json::object();  ///< {filename, format, bytes, counts?}
  nlohmann::json stats;                             ///< the worker's --stats JSON once succeeded
  nlohmann::json error;                             ///< problem object once failed/cancelled
  std::uint64_t result_bytes = 0;
  std::string idempotency_key, fingerprint;
  int attempts = 0;
  bool sync = false;  ///< created by POST /v1/curve (not listed)

  bool terminal() const { return status == "succeeded" || status == "failed" || status == "cancelled"; }
};

/// The public JSON view of a job (what GET /v1/jobs/{id} answers).
nlohmann::json job_view(const Job& job);

/// The persisted JSON of a job, and back.
nlohmann::json job_to_state(const Job& job);
Job job_from_state(const nlohmann::json& state);

/// Writes `text` to `path` atomically: temp file, fsync, rename, fsync of the directory.
void write_file_atomic(const std::string& path, const std::string& text);

class JobStore {
 public:
  /// Creates the folders and takes the data directory's lock; throws when another process holds it.
  explicit JobStore(std::string data_dir);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  /// Checks that the data directory is still there and its lock file is still the one this store
  /// holds: deleting the directory (or the lock file) while the daemon runs would let a second
  /// daemon in. A lost lock is taken again on a new lock file (the job and upload folders are made
  /// again) unless another process holds that one. Returns "" when the store is usable, else why
  /// not (for a 503 storage-unavailable). Logs each change. Cheap (two stat calls) when all is well.
  std::string check_storage();

  /// Loads every jobs/<id>/state.json; removes folders without one (interrupted uploads).
  /// Returns the loaded jobs, oldest first.
  std::vector<Job> load();

  /// A new unique, time-ordered id (lexicographic order = creation order).
  std::string new_id();
  std::string job_dir(const std::string& id) const;
  std::string uploads_dir() const;

  /// Deletes the temporary files an interrupted atomic write left in job id's folder (a worker
  /// killed while writing its result leaves megabytes that nothing else would remove).
  void remove_leftovers(const std::string& id) const;

  /// Adds (and persists) a new job; the job's folder must exist.
  void insert(const Job& job);
  std::optional<Job> get(const std::string& id) const;
  /// Applies `fn` to the job under the lock and persists it; returns the updated job.
  std::optional<Job> update(const std::string& id, const std::function<void(Job&)>& fn, bool persist = true);
  /// Removes the job and its folder. False when there is no such job, or (with `error` set) when
  /// its state file cannot be deleted: the job then stays, as it would after a restart.
  bool remove(const std::string& id, std::string* error = nullptr);
  /// Newest first, ids strictly older than `after` when given; sync jobs are not listed.
  std::vector<Job> list(size_t limit, const std::string& after, const std::string& status, bool& more) const;
  std::vector<Job> all() const;
  std::optional<Job> find_idempotent(const std::string& key) const;

  /// Waits until the job is terminal (or gone, or `timeout_s` elapsed); returns its last state.
  /// A terminal state is on disk when it is returned.
  std::optional<Job> wait_terminal(const std::string& id, double timeout_s);

  /// Counts by status.
  std::map<std::string, long long> counts() const;

  /// Bytes held in the data directory by all jobs: every file of their folders, as counted when
  /// each job was added, loaded or last recounted.
  std::uint64_t disk_bytes() const;
  /// Counts job id's folder again (after its worker wrote the result, stats and log).
  void recount(const std::string& id);
  /// Sets `bytes` of `quota` aside for an upload in progress, unless the jobs' bytes and the other
  /// uploads' reservations leave less room (then false, nothing set aside): parallel uploads each
  /// checked against the jobs alone overshot the quota together.
  bool reserve(std::uint64_t bytes, std::uint64_t quota);
  /// Gives back what reserve() set aside (once the upload is a job, counted in disk_bytes, or gone).
  void release(std::uint64_t bytes);
  /// Bytes set aside by uploads in progress.
  std::uint64_t reserved_bytes() const;

 private:
  void persist(const Job& job) const;
  /// Writes version `v` of the job unless a newer one was written already. Runs without `mutex_`
  /// so that readers never wait for an fsync.
  void persist_version(const Job& job, std::uint64_t v);
  std::string data_dir_;
  std::string lock_path() const;
  std::string take_lock_again();
  int lock_fd_ = -1;  ///< flock'ed data_dir/lock (under storage_mutex_ once serving)
  bool lock_held_ = false;  ///< false on a file system without locks: nothing to check
  std::mutex storage_mutex_;
  std::string storage_problem_;  ///< the last check_storage answer (under storage_mutex_)
  mutable std::mutex mutex_;
  std::mutex persist_mutex_;
  std::map<std::string, std::uint64_t> versions_;  // under mutex_
  std::map<std::string, std::uint64_t> written_;   // under persist_mutex_
  mutable std::condition_variable changed_;
  std::map<std::string, Job> jobs_;
  std::map<std::string, std::string> idempotency_;  // key -> id
  std::map<std::string, std::uint64_t> counted_;  // bytes of each job's folder in disk_bytes_ (under mutex_)
  std::uint64_t disk_bytes_ = 0;
  std::uint64_t reserved_ = 0;  // under mutex_
  std::uint64_t id_counter_ = 0;
};

}  // namespace hocurve::server
