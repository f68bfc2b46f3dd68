#include "cli/common.hpp"

#include "engine/core/error.hpp"

#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <unistd.h>

namespace hocurve::cli {

void Progress::operator()(const std::string& stage, double fraction) const {
  if (!enabled) return;
  nlohmann::json j = {{"stage", stage}, {"fraction", fraction}};
  std::cout << j.dump() << "\n" << std::flush;
}

double now_seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

void print_input_warnings(const std::string& cmd, const LoadedInput& in) {
  for (const auto* list : {&in.read.warnings, &in.validation.warnings})
    for (const std::string& w : *list) std::cerr << "hocurve " << cmd << ": warning: " << w << "\n";
}

LoadedInput load_input(const std::string& path, const Progress& progress, const ReadOptions& read) {
  LoadedInput in;
  progress("read", 0.0);
  double t0 = now_seconds();
  ReadResult r = read_mesh_file(path, read);
  in.mesh = std::move(r.mesh);
  in.read = std::move(r.report);
  double t1 = now_seconds();
  progress("validate", 0.05);
  ValidateOptions vo;
  vo.name = path;  // messages and warnings name the file, as the reader's do
  in.validation = validate_mesh(in.mesh, vo);
  in.read_seconds = t1 - t0;
  in.validate_seconds = now_seconds() - t1;
  return in;
}

nlohmann::json input_json(const std::string& path, const LoadedInput& in) {
  const auto& v = in.validation;
  return {
      {"file", path},
      {"format", in.read.format},
      {"gzip", in.read.gzip},
      {"vertices", in.mesh.num_vertices()},
      {"faces", in.mesh.num_faces()},
      {"facets_read", in.read.facets_read},
      {"welded_vertices", in.read.welded_vertices},
      {"physical_groups", in.mesh.physicals.size()},
      {"validation",
       {{"components", v.components},
        {"boundary_edges", v.boundary_edges},
        {"nonmanifold_edges", v.nonmanifold_edges},
        {"nonmanifold_vertices", v.nonmanifold_vertices},
        {"flipped_faces", v.flipped_faces},
        {"non_orientable_components", v.non_orientable_components},
        {"duplicate_faces_removed", v.duplicate_faces},
        {"degenerate_faces_removed", v.degenerate_faces},
        {"zero_area_faces", v.zero_area_faces},
        {"zero_area_caps_flipped", v.zero_area_caps_flipped},
        {"zero_area_flaps_removed", v.zero_area_flaps_removed},
        {"unused_vertices_removed", v.unused_vertices}}},
      {"warnings", [&] {
         auto w = in.read.warnings;
         w.insert(w.end(), v.warnings.begin(), v.warnings.end());
         return w;
       }()},
      {"seconds", {{"read", in.read_seconds}, {"validate", in.validate_seconds}}},
  };
}

void check_output_path(const std::string& option, const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(path).has_parent_path() ? fs::path(path).parent_path() : fs::path(".");
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw UsageError(option + " " + path + " is a directory, not a file");
  if (!fs::is_directory(dir, ec))
    throw UsageError("cannot write " + option + " " + path + ": the folder " + dir.string() + " does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw UsageError("cannot write " + option + " " + path + ": the folder " + dir.string() + " is not writable");
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw UsageError("cannot write " + path + ": cannot open for writing");
    f << j.dump(2) << "\n";
    if (!f.flush()) throw UsageError("cannot write " + path + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw UsageError("cannot write " + path + ": cannot rename the temporary file into place");
  }
}

std::optional<Args> parse_command(const std::string& cmd, int argc, char** argv, const std::vector<OptionSpec>& specs,
                                  const char* usage) {
  Args a = parse_args(argc, argv, 2, specs);
  if (a.has("help")) {
    std::cout << usage << "\noptions:\n" << options_help(specs);
    return std::nullopt;
  }
  if (a.positional.size() != 1) throw UsageError(cmd + " needs exactly one INPUT file (see --help)");
  if (!a.has("output")) throw UsageError(cmd + " needs -o OUTPUT.msh");
  check_output_path("-o", a.get("output"));
  if (a.has("stats")) check_output_path("--stats", a.get("stats"));
  return a;
}

std::unique_ptr<tbb::global_control> thread_limit(int threads) {
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, size_t(threads));
}

int run_guarded(const std::function<int()>& command) {
  try {
    return command();
  } catch (const UsageError& e) {
    std::cerr << "hocurve: usage error: " << e.what() << "\n";
    return 2;
  } catch (const InputError& e) {
    std::cerr << "hocurve: input refused: " << e.what() << "\n";
    return 3;
  } catch (const std::bad_alloc&) {
    std::cerr << "hocurve: out of memory: the mesh needs more memory than this process may use\n";
    return 5;
  } catch (const std::exception& e) {
    std::cerr << "hocurve: internal error: " << e.what() << "\n";
    return 4;
  } catch (...) {
    std::cerr << "hocurve: internal error: unknown exception\n";
    return 4;
  }
}

int exec_sibling(const char* name, char** argv) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::string path = (ec ? std::filesystem::path(argv[0]).parent_path() : self.parent_path()) / name;
  argv[0] = const_cast<char*>(path.c_str());
  execv(path.c_str(), argv);
  throw std::runtime_error("cannot run " + path + " (" + std::strerror(errno) + "): it is built and installed beside hocurve");
}

}  // namespace hocurve::cli
