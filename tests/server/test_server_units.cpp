// Unit tests of hocurved's pieces that need no HTTP: option validation, worker command line, format
// sniffing, chunked framing, the Prometheus text, and the durable job store (atomic state, reload,
// pagination, quota reservations).
#include "cli/option_registry.hpp"
#include "server/byte_range.hpp"
#include "server/format_sniff.hpp"
#include "server/http_server.hpp"
#include "server/job_options.hpp"
#include "server/job_store.hpp"
#include "server/metrics.hpp"
#include "server/problem.hpp"

#include <doctest/doctest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <sys/file.h>
#include <thread>
#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

using namespace hocurve::server;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {
std::string binary_stl(std::uint32_t facets, std::uint32_t declared) {
  std::string s(80, ' ');
  s.replace(0, 9, "test part");
  s.append(reinterpret_cast<const char*>(&declared), 4);
  s.append(50ull * facets, '\0');
  return s;
}

std::vector<std::string> pointers(const ApiError& e) {
  std::vector<std::string> out;
  for (auto& x : e.extra.at("errors")) out.push_back(x.at("pointer"));
  return out;
}

std::string temp_dir(const char* name) {
  fs::path p = fs::temp_directory_path() / (std::string(name) + "-" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

/// Locks dir/lock through another open file (flock: it conflicts with the store's, as another
/// process's would); the descriptor, or -1.
int lock_elsewhere(const std::string& dir) {
  const int fd = ::open((dir + "/lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd >= 0 && ::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}
}  // namespace

TEST_CASE("options: defaults are filled and strings from a query are typed") {
  json o = normalise_options(json::object());
  CHECK(o == json({{"mode", "curve"}, {"order", 4}, {"nodes", "equispaced"}, {"format", "msh41"}, {"binary", false}}));
  o = normalise_options({{"order", "5"}, {"binary", "1"}, {"nodes", "equispaced"}, {"format", "msh22"}});
  CHECK(o["order"] == 5);
  CHECK(o["binary"] == true);
  o = normalise_options({{"mode", "coarsen"}, {"ratio", "0.05"}, {"order", 4}});
  CHECK(o == json({{"mode", "coarsen"}, {"order", 4}, {"ratio", 0.05}}));
  o = normalise_options({{"mode", "coarsen"}, {"faces", 100}, {"max_deviation", "0"}});
  CHECK(o["max_deviation"] == 0.0);
}

TEST_CASE("options: every offending key is reported with a JSON pointer") {
  for (const char* bad : {"0", "1", "7", "99", "-3", "3.5", "abc", ""}) {
    try {
      normalise_options({{"order", bad}});
      FAIL("order " << bad << " accepted");
    } catch (const ApiError& e) {
      CHECK(e.status == 400);
      CHECK(e.type == "invalid-options");
      CHECK(pointers(e) == std::vector<std::string>{"/options/order"});
    }
  }
  try {
    normalise_options({{"order", 99}, {"smooth", true}, {"nodes", "gauss"}});
    FAIL("accepted");
  } catch (const ApiError& e) {
    auto p = pointers(e);
    CHECK(p.size() == 3);
    CHECK(std::string(e.what()).find("unknown option 'smooth'") != std::string::npos);
  }
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}}), ApiError);                                // neither
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 10}, {"ratio", 0.5}}), ApiError);  // both
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 10}, {"binary", 1}}), ApiError);  // curve-only key
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 10}, {"tangent_junctions", true}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"tangent_junctions", "maybe"}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 10}, {"exact_quadrics", false}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"exact_quadrics", 2}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"faces", 10}}), ApiError);                                      // coarsen-only key
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"ratio", 0}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"ratio", 0.1}, {"max_deviation", -1}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"max_deviation", 0.01}}), ApiError);  // coarsen-only key
  CHECK_THROWS_AS(normalise_options({{"tolerance", 0.005}}), ApiError);      // coarsen-only key
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"ratio", 0.1}, {"tolerance", -1}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"ratio", 0.1}, {"max_faces", 100}}), ApiError);  // needs tolerance
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"ratio", 0.1}, {"tolerance", 0.005}, {"max_faces", 2}}), ApiError);
  CHECK_THROWS_AS(normalise_options(json::array()), ApiError);
  CHECK_THROWS_AS(options_from_query({{"order", "3"}, {"order", "4"}}), ApiError);
}

TEST_CASE("options: the keys, ranges and messages are the option registry's") {
  for (const auto& d : hocurve::cli::option_registry()) {
    if (!d.modes || (d.type != hocurve::cli::OptionType::Int && d.type != hocurve::cli::OptionType::Number)) continue;
    CAPTURE(d.key);
    json raw = {{d.key, hocurve::cli::job_lo(d) - 1}};
    if (d.modes == hocurve::cli::kCoarsen) raw["mode"] = "coarsen";
    try {
      normalise_options(raw);
      FAIL("accepted below its range");
    } catch (const ApiError& e) {
      CHECK(std::string(e.what()).find(std::string(d.key) + " must be ") != std::string::npos);
    }
  }
  try {
    normalise_options({{"order", "1"}});  // the CLI's order 1 is no job
    FAIL("accepted");
  } catch (const ApiError& e) {
    CHECK(std::string(e.what()) == "order must be an integer from 2 to 6, got 1");
  }
  try {
    normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"long_edge_ratio", -1}});
    FAIL("accepted");
  } catch (const ApiError& e) {
    CHECK(std::string(e.what()) == "long_edge_ratio must be a number in [0, 1e9] (0: off), got -1");
  }
}

TEST_CASE("worker command line follows the CLI contract") {
  auto a = worker_argv("/bin/hocurve", normalise_options({{"order", 4}, {"binary", true}}), "in.stl", "out.msh", "s.json", 2);
  CHECK(a == std::vector<std::string>{"/bin/hocurve", "curve", "in.stl", "-o", "out.msh", "--order", "4", "--nodes",
                                      "equispaced", "--format", "msh41", "--binary", "--threads", "2", "--stats", "s.json",
                                      "--progress"});
  a = worker_argv("h", normalise_options({{"tangent_junctions", "0"}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "curve", "i", "-o", "o", "--order", "4", "--nodes", "equispaced", "--format",
                                      "msh41", "--tangent-junctions", "off", "--threads", "1", "--stats", "s",
                                      "--progress"});
  a = worker_argv("h", normalise_options({{"exact_quadrics", false}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "curve", "i", "-o", "o", "--order", "4", "--nodes", "equispaced", "--format",
                                      "msh41", "--exact-quadrics", "off", "--threads", "1", "--stats", "s",
                                      "--progress"});
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"faces", 500}, {"order", 2}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "2", "--faces", "500", "--stats", "s",
                                      "--progress"});
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"ratio", 0.5}, {"max_deviation", 0.02}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--ratio", "0.5",
                                      "--max-deviation", "0.02", "--stats", "s", "--progress"});
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"ratio", 0.04}, {"tolerance", 0.005}, {"max_faces", "330"}}),
                  "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--ratio", "0.040000000000000001",
                                      "--tolerance", "0.0050000000000000001", "--max-faces", "330", "--stats", "s",
                                      "--progress"});
  // The feature threshold and the long-edge rule, in both modes; refused out of range.
  a = worker_argv("h", normalise_options({{"feature_angle", "40"}, {"long_edge_ratio", 0}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "curve", "i", "-o", "o", "--order", "4", "--nodes", "equispaced", "--format",
                                      "msh41", "--feature-angle", "40", "--long-edge-ratio", "0", "--threads", "1",
                                      "--stats", "s", "--progress"});
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"long_edge_ratio", 3.5}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--faces", "50",
                                      "--long-edge-ratio", "3.5", "--stats", "s", "--progress"});
  CHECK_THROWS_AS(normalise_options({{"feature_angle", 181}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"feature_angle", "sharp"}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"long_edge_ratio", -1}}), ApiError);
  // The quality floor, in both modes.
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"min_jacobian", "0.1"}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--faces", "50",
                                      "--min-jacobian", "0.10000000000000001", "--stats", "s", "--progress"});
  CHECK_THROWS_AS(normalise_options({{"min_jacobian", 1}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"min_jacobian", -0.1}}), ApiError);
  // The reader's weld tolerance, in both modes.
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"weld_tolerance", 0}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--faces", "50",
                                      "--weld-tolerance", "0", "--stats", "s", "--progress"});
  CHECK_THROWS_AS(normalise_options({{"weld_tolerance", 0.5}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"weld_tolerance", -1e-9}}), ApiError);
  // Re-decimation rounds: coarsen only, 0..100.
  a = worker_argv("h", normalise_options({{"mode", "coarsen"}, {"ratio", 0.05}, {"redecimate", "2"}}), "i", "o", "s", 1);
  CHECK(a == std::vector<std::string>{"h", "coarsen", "i", "-o", "o", "--order", "4", "--ratio", "0.050000000000000003",
                                      "--redecimate", "2", "--stats", "s", "--progress"});
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"redecimate", 101}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"mode", "coarsen"}, {"faces", 50}, {"redecimate", 1.5}}), ApiError);
  CHECK_THROWS_AS(normalise_options({{"redecimate", 2}}), ApiError);  // mode=curve
}

TEST_CASE("format sniffing and the upload-time binary STL count check") {
  CHECK(sniff_mesh(binary_stl(10, 10), 84 + 500, "").format == "stl-binary");
  CHECK(sniff_mesh(binary_stl(10, 10), 84 + 500, "").refusal.empty());
  auto lying = sniff_mesh(binary_stl(10, 1000), 84 + 500, "");
  CHECK(lying.refusal.find("declares 1000 facets but its 584 bytes hold 10") != std::string::npos);
  std::string truncated = binary_stl(10, 10).substr(0, 84 + 470);
  CHECK(sniff_mesh(truncated, truncated.size(), "").refusal.find("truncated") != std::string::npos);
  CHECK(sniff_mesh(binary_stl(0, 0), 84, "").refusal == "binary STL declares 0 facets");
  // A binary header that starts with "solid" is still binary when the size matches.
  std::string solid_binary = binary_stl(3, 3);
  solid_binary.replace(0, 5, "solid");
  CHECK(sniff_mesh(solid_binary, solid_binary.size(), "").format == "stl-binary");
  std::string ascii = "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n";
  CHECK(sniff_mesh(ascii, ascii.size(), "").format == "stl-ascii");
  CHECK(sniff_mesh("# obj\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 40, "").format == "obj");
  CHECK(sniff_mesh("ply\nformat ascii 1.0\n", 20, "").format == "ply");
  CHECK(sniff_mesh("OFF\n3 1 0\n", 10, "").format == "off");
  CHECK(sniff_mesh("$MeshFormat\n4.1 0 8\n", 20, "").format == "msh");
  auto gz = sniff_mesh(std::string("\x1f\x8b\x08\x00", 4), 100, "part.STL.gz");
  CHECK(gz.format == "gzip");
  CHECK(gz.extension == ".stl.gz");
  CHECK(sniff_mesh("hello world, this is not a mesh\n", 32, "").format.empty());
  CHECK(sniff_mesh("", 0, "").refusal == "the upload is empty");
  std::string garbage(5000, '\0');
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = char((i * 2654435761u) >> 13);
  auto g = sniff_mesh(garbage, garbage.size(), "");
  CHECK((g.format.empty() || !g.refusal.empty()));  // never accepted as a mesh
}

std::string gzipped(const std::string& data) {
  z_stream z{};
  deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 9, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, data.size()) + 64, '\0');
  z.next_in = (Bytef*)data.data();
  z.avail_in = (uInt)data.size();
  z.next_out = (Bytef*)out.data();
  z.avail_out = (uInt)out.size();
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

TEST_CASE("format sniffing: gzip by what it inflates to, OBJ opening with group lines") {
  const std::string stl = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                          "endloop\nendfacet\nendsolid t\n";
  const std::string gz = gzipped(stl);
  CHECK(sniff_mesh(gz, gz.size(), "").format == "gzip");
  CHECK(sniff_mesh(gz, gz.size(), "").refusal.empty());
  const std::string bomb = gzipped(std::string(64 << 20, '\0'));  // 64 MiB of zeros in ~64 KB
  const auto b = sniff_mesh(bomb.substr(0, 65536), bomb.size(), "");
  CHECK(b.format == "gzip");
  CHECK(b.refusal.find("inside the gzip file") != std::string::npos);
  const std::string text = gzipped(std::string(100000, 'a'));
  CHECK(sniff_mesh(text, text.size(), "").format.empty());  // 415: no mesh inside
  std::string obj;
  for (int i = 0; i < 2000; ++i) obj += "g group" + std::to_string(i) + "\no part\nusemtl m\n";
  CHECK(sniff_mesh(obj.substr(0, 65536), obj.size() + 100, "").format == "obj");  // no vertex yet in the head
  CHECK(sniff_mesh("g\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 34, "").format == "obj");
  CHECK(sniff_mesh("g only groups\n", 14, "").format.empty());  // whole and without a vertex
  CHECK(sniff_mesh("gopher 1 2\nv 0 0 0\n", 19, "").format.empty());
}

TEST_CASE("chunked framing: RFC 9112 7.1 only, fed whole or a byte at a time") {
  auto whole = [](const std::string& body) {
    ChunkedFraming f;
    return f.feed(body.data(), body.size()) && f.done();
  };
  auto bytewise = [](const std::string& body) {
    ChunkedFraming f;
    for (char c : body)
      if (!f.feed(&c, 1)) return false;
    return f.done();
  };
  for (const std::string good : {"5\r\nhello\r\n0\r\n\r\n", "5;a=b\r\nhello\r\n0\r\n\r\n", "5 ;a\r\nhello\r\n0\r\n\r\n",
                                 "A\r\n0123456789\r\n0\r\nX-T: 1\r\n\r\n", "0\r\n\r\n"}) {
    CHECK_MESSAGE(whole(good), good);
    CHECK_MESSAGE(bytewise(good), good);
  }
  for (const std::string bad : {"0x5\r\nhello\r\n0\r\n\r\n", " 5\r\nhello\r\n0\r\n\r\n", "+5\r\nhello\r\n0\r\n\r\n",
                                "-1\r\nhello\r\n0\r\n\r\n", "5\nhello\n0\n\n", "5\r\nhelloXX0\r\n\r\n",
                                "5 x\r\nhello\r\n0\r\n\r\n", "1000000000000000\r\n", "0\r\n bad\r\n\r\n", "0\r\n\n"}) {
    CHECK_MESSAGE(!whole(bad), bad);
    CHECK_MESSAGE(!bytewise(bad), bad);
  }
  ChunkedFraming partial;
  CHECK(partial.feed("5\r\nhel", 8));
  CHECK(!partial.done());
}

TEST_CASE("job store: uploads in progress reserve their length in the quota") {
  const std::string dir = (fs::temp_directory_path() / ("hocurved-reserve-" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  {
    JobStore store(dir);
    CHECK(store.reserve(400, 1000));
    CHECK(store.reserve(400, 1000));
    CHECK(!store.reserve(400, 1000));  // 1200 > 1000: refused, nothing set aside
    CHECK(store.reserved_bytes() == 800);
    store.release(400);
    CHECK(store.reserve(600, 1000));
    store.release(400);
    store.release(600);
    CHECK(store.reserved_bytes() == 0);
  }
  fs::remove_all(dir);
}

TEST_CASE("Prometheus text: histogram and label escaping (golden)") {
  Histogram h({0.5, 1});
  h.observe(0.25);
  h.observe(0.75);
  h.observe(3);
  std::string out;
  h.render(out, "x_seconds", "route=\"/a\"");
  CHECK(out ==
        "x_seconds_bucket{route=\"/a\",le=\"0.5\"} 1\n"
        "x_seconds_bucket{route=\"/a\",le=\"1\"} 2\n"
        "x_seconds_bucket{route=\"/a\",le=\"+Inf\"} 3\n"
        "x_seconds_sum{route=\"/a\"} 4\n"
        "x_seconds_count{route=\"/a\"} 3\n");
  CHECK(escape_label("a\"b\\c\nd") == "a\\\"b\\\\c\\nd");
  Metrics m;
  m.count_request("GET", "/v1/jobs/{id}", 200, 0.002);
  m.job_finished("succeeded", 1.5);
  GaugeSnapshot g;
  g.jobs_by_state = {{"queued", 2}, {"running", 1}};
  g.queue_depth = 2;
  std::string text = m.render(g, "9.9.9");
  CHECK(text.back() == '\n');
  CHECK(text.find("hocurve_build_info{version=\"9.9.9\",api_version=\"1\"} 1\n") != std::string::npos);
  CHECK(text.find("hocurve_jobs{state=\"queued\"} 2\n") != std::string::npos);
  CHECK(text.find("hocurve_http_requests_total{method=\"GET\",route=\"/v1/jobs/{id}\",code=\"200\"} 1\n") !=
        std::string::npos);
  CHECK(text.find("hocurve_job_duration_seconds_bucket{le=\"2\"} 1\n") != std::string::npos);
  CHECK(text.find("hocurve_job_duration_seconds_bucket{le=\"1\"} 0\n") != std::string::npos);
  // Every sample belongs to a family declared before it.
  std::set<std::string> declared;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# TYPE ", 0) == 0) declared.insert(line.substr(7, line.find(' ', 7) - 7));
    if (line[0] == '#') continue;
    std::string name = line.substr(0, line.find_first_of("{ "));
    for (const char* suffix : {"_bucket", "_sum", "_count"})
      if (!declared.count(name) && name.size() > strlen(suffix) &&
          name.compare(name.size() - strlen(suffix), strlen(suffix), suffix) == 0)
        name = name.substr(0, name.size() - strlen(suffix));
    CHECK_MESSAGE(declared.count(name), line);
  }
}

TEST_CASE("job store: atomic state, reload, pagination, idempotency keys") {
  const std::string dir = temp_dir("hocurved-store");
  std::vector<std::string> ids;
  {
    JobStore store(dir);
    for (int i = 0; i < 7; ++i) {
      Job j;
      j.id = store.new_id();
      j.created = 1000 + i;
      j.options = {{"order", 2 + i % 3}};
      j.idempotency_key = i == 3 ? "k3" : "";
      j.status = i % 2 ? "succeeded" : "queued";
      fs::create_directories(store.job_dir(j.id));
      store.insert(j);
      ids.push_back(j.id);
    }
    CHECK(std::is_sorted(ids.begin(), ids.end()));
    store.update(ids[0], [](Job& j) { j.status = "running"; j.stage = "fits"; j.fraction = 0.5; });
    fs::create_directories(dir + "/jobs/00000000000000000000dead");  // interrupted upload: no state.json
  }
  JobStore store(dir);
  auto loaded = store.load();
  REQUIRE(loaded.size() == 7);
  CHECK(!fs::exists(dir + "/jobs/00000000000000000000dead"));
  auto j0 = store.get(ids[0]);
  REQUIRE(j0);
  CHECK(j0->status == "running");
  CHECK(j0->fraction == 0.5);
  CHECK(j0->options == json({{"order", 2}}));
  CHECK(store.find_idempotent("k3")->id == ids[3]);
  CHECK(!fs::exists(store.job_dir(ids[0]) + "/state.json.tmp"));

  bool more = false;
  auto page1 = store.list(3, "", "", more);
  CHECK(more);
  REQUIRE(page1.size() == 3);
  CHECK(page1[0].id == ids[6]);  // newest first
  auto page2 = store.list(3, page1.back().id, "", more);
  CHECK(page2[0].id == ids[3]);
  auto page3 = store.list(3, page2.back().id, "", more);
  CHECK(page3.size() == 1);
  CHECK(!more);
  auto done = store.list(10, "", "succeeded", more);
  CHECK(done.size() == 3);
  CHECK(store.counts()["queued"] == 3);

  CHECK(store.remove(ids[3]));
  CHECK(!store.get(ids[3]));
  CHECK(!store.find_idempotent("k3"));
  CHECK(!fs::exists(store.job_dir(ids[3])));
  fs::remove_all(dir);
}

TEST_CASE("byte ranges: one range served, clipped, past the end unsatisfiable, the rest ignored") {
  auto part = [](const std::string& h, std::uint64_t size) {
    ByteRange r = parse_byte_range(h, size);
    return r.kind == ByteRange::kPart ? content_range(r, size) : r.kind == ByteRange::kWhole ? "whole" : "416";
  };
  CHECK(part("bytes=0-9", 100) == "bytes 0-9/100");
  CHECK(part("bytes=90-", 100) == "bytes 90-99/100");
  CHECK(part("bytes=99999999-", 100) == "416");  // "first-" runs to the end, wherever that is
  CHECK(part("bytes=-5", 100) == "bytes 95-99/100");
  CHECK(part("bytes=-500", 100) == "bytes 0-99/100");
  CHECK(part("bytes=50-5000", 100) == "bytes 50-99/100");
  CHECK(part(" BYTES = 7-7 ", 100) == "bytes 7-7/100");
  CHECK(part("bytes=100-", 100) == "416");
  CHECK(part("bytes=100-200", 100) == "416");
  CHECK(part("bytes=-0", 100) == "416");
  CHECK(part("bytes=0-", 0) == "416");
  for (const char* ignored : {"", "bytes=0-1,5-6", "items=0-5", "bytes=abc", "bytes=9-2", "bytes=-", "bytes=1-2-3",
                              "bytes=0x10-", "bytes=1234567890123456789-"})
    CHECK_MESSAGE(part(ignored, 100) == "whole", ignored);
  // What the HTTP library would refuse (416 before routing): the server hides these from it.
  for (const char* refused : {"bytes=abc", "items=0-5", "bytes=5-2", "BYTES=0-9", "bytes= 0-5", "bytes=0-1-2",
                              "bytes=99999999999999999999999-"})
    CHECK_MESSAGE(httplib_refuses_range(refused), refused);
  for (const char* parsed : {"bytes=0-9", "bytes=5-", "bytes=-5", "bytes=0-1, 5-6", "bytes=-"})
    CHECK_MESSAGE(!httplib_refuses_range(parsed), parsed);
}

TEST_CASE("job store: a deleted data directory and its lost lock") {
  const std::string dir = temp_dir("hocurve-lock");
  JobStore store(dir);
  CHECK(store.check_storage().empty());
  CHECK_THROWS(JobStore(dir));
  fs::remove_all(dir);
  CHECK(store.check_storage().find("is gone") != std::string::npos);
  fs::create_directories(dir);
  CHECK(store.check_storage().empty());  // a new lock file, locked; the folders made again
  CHECK(fs::is_directory(store.uploads_dir()));
  CHECK_THROWS(JobStore(dir));
  // Lock file replaced by one another process holds (flock: another open file conflicts too).
  fs::remove(dir + "/lock");
  const int other = lock_elsewhere(dir);
  REQUIRE(other >= 0);
  CHECK(store.check_storage().find("another process") != std::string::npos);
  ::close(other);
  CHECK(store.check_storage().empty());
  CHECK_THROWS(JobStore(dir));
  fs::remove_all(dir);
}

TEST_CASE("job store: a lock held for a moment is waited for, one held on is refused") {
  // After kill -9 a worker forked just before holds a copy of the lock's descriptor until it
  // execs or dies: here another open file of the lock, released after 0.3 s.
  const std::string dir = temp_dir("hocurve-lock-wait");
  const int other = lock_elsewhere(dir);
  REQUIRE(other >= 0);
  std::thread release([other] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ::close(other);
  });
  CHECK_NOTHROW(JobStore{dir});
  release.join();
  const int held = lock_elsewhere(dir);
  REQUIRE(held >= 0);
  CHECK_THROWS_WITH(JobStore{dir}, doctest::Contains("another hocurved"));
  ::close(held);
  fs::remove_all(dir);
}

TEST_CASE("problem objects carry type URI, code, title, status and extensions") {
  json p = make_problem(429, "queue-full", "full", {{"retry_after", 2}});
  CHECK(p["type"] == "https://hocurve.dev/problems/queue-full");
  CHECK(p["code"] == "queue-full");
  CHECK(p["title"] == "Job queue is full");
  CHECK(p["status"] == 429);
  CHECK(p["retry_after"] == 2);
}
