// libFuzzer harness of one reader: HOCURVE_FUZZ_NAME ("fuzz.stl", "fuzz.gz", ...) is the name hint,
// the seed corpus (tests/fuzz/make_seeds.py) holds that format; detection still runs on content,
// as in the product, so mutations may cross into another reader.
#include "fuzz/fuzz_one.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hocurve_fuzz::read_one(std::string_view(reinterpret_cast<const char*>(data), size), HOCURVE_FUZZ_NAME);
  return 0;
}
