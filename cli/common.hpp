// What every sub-command shares: loading and validating the input, progress lines, stats JSON.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/io/read_mesh.hpp"
#include "cli/args.hpp"
#include "engine/io/validate_mesh.hpp"

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace hocurve::cli {

/// Reports stage progress as JSON lines on stdout when enabled (the daemon's worker protocol).
struct Progress {
  bool enabled = false;
  void operator()(const std::string& stage, double fraction) const;
};

/// A read and validated input mesh with its reports.
struct LoadedInput {
  Mesh mesh;
  ReadReport read;
  ValidateReport validation;
  double read_seconds = 0, validate_seconds = 0;
};

/// Reads and validates a mesh file; throws InputError with file and location on refusal.
/// Prints the reader's and validation's warnings on stderr, one line each, prefixed "hocurve CMD: warning: ".
void print_input_warnings(const std::string& cmd, const LoadedInput& in);

LoadedInput load_input(const std::string& path, const Progress& progress, const ReadOptions& read = {});

/// The input part of the stats JSON (format, counts, repairs, warnings, timings).
nlohmann::json input_json(const std::string& path, const LoadedInput& in);

/// Throws UsageError (exit 2) unless `path`'s folder exists and is writable: checked before any
/// work, so that a mistyped -o or --stats does not cost a whole run and an "internal error".
void check_output_path(const std::string& option, const std::string& path);

/// Parses the command line of `hocurve CMD INPUT -o OUTPUT ...`: prints usage and the options
/// and returns nothing for --help; otherwise throws UsageError unless there is exactly one INPUT
/// and a -o, and checks the -o and --stats paths (check_output_path).
std::optional<Args> parse_command(const std::string& cmd, int argc, char** argv, const std::vector<OptionSpec>& specs,
                                  const char* usage);

/// Runs a command, turning its exceptions into the documented exit codes and one line on stderr:
/// 2 usage error, 3 input refused, 4 internal error, 5 out of memory.
int run_guarded(const std::function<int()>& command);

/// Replaces this process by program `name` from this executable's folder, with the same arguments
/// (argv[0] becomes its path); returns only on failure, by throwing. Why: `hocurve volume` links
/// Gmsh's 90 shared libraries (0.07 s and 45 MB at every start), which curve and coarsen need not.
int exec_sibling(const char* name, char** argv);

/// The TBB thread limit for --threads N (null for 0: all cores); keep it alive while working.
std::unique_ptr<tbb::global_control> thread_limit(int threads);

/// Writes JSON to a file atomically (temporary file, then rename).
void write_json_file(const std::string& path, const nlohmann::json& j);

/// Wall-clock seconds since an arbitrary origin.
double now_seconds();

}  // namespace hocurve::cli
