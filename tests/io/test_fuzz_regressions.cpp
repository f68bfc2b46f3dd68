// Replays tests/fuzz/regressions/: inputs on which fuzzing once found a crash, a hang, a leak, UB or a
// non-InputError exception. Each must now be read or refused with InputError (under ASan/UBSan in
// the asan build). A file's name starts with its harness: stl-, obj-, ply-, off-, msh- or gzip-.
#include <doctest/doctest.h>

#include "fuzz/fuzz_one.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace fs = std::filesystem;

TEST_CASE("fuzzing regressions are read or refused with InputError") {
  const fs::path dir = fs::path(HOCURVE_SOURCE_DIR) / "tests" / "fuzz" / "regressions";
  REQUIRE(fs::is_directory(dir));
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename() != "README.md") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  int read = 0, refused = 0;
  for (const fs::path& p : files) {
    const std::string leaf = p.filename().string();
    CAPTURE(leaf);
    const std::string harness = leaf.substr(0, leaf.find('-'));
    REQUIRE((harness == "stl" || harness == "obj" || harness == "ply" || harness == "off" || harness == "msh" ||
             harness == "gzip"));
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string name = harness == "gzip" ? "fuzz.gz" : "fuzz." + harness;
    (hocurve_fuzz::read_one(ss.str(), name) ? read : refused)++;
  }
  MESSAGE(files.size() << " regression inputs: " << read << " read, " << refused << " refused");
}
