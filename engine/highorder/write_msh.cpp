// Streaming .msh writer: text through std::to_chars (shortest round-trip doubles) into a large
// buffer, binary as raw little-endian words; no per-node iostream formatting.
#include "engine/highorder/write_msh.hpp"

#include "engine/core/error.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <oneapi/tbb/parallel_pipeline.h>

#include <fcntl.h>
#include <unistd.h>

namespace hocurve {

namespace {

static_assert(std::endian::native == std::endian::little, "binary .msh output assumes a little-endian host");

// Output buffer that hands full chunks to a sink.
class Out {
 public:
  explicit Out(std::function<void(const char*, size_t)> sink, size_t size = size_t(4) << 20)
      : sink_(std::move(sink)) {
    buf_.resize(size);
  }
  // Guarantees room for n more bytes.
  void reserve(size_t n) {
    if (pos_ + n > buf_.size()) {
      flush();
      if (n > buf_.size()) buf_.resize(n);
    }
  }
  void flush() {
    if (pos_) sink_(buf_.data(), pos_);
    pos_ = 0;
  }
  void str(const char* s) { raw(s, std::strlen(s)); }
  void str(const std::string& s) { raw(s.data(), s.size()); }
  void raw(const void* p, size_t n) {
    if (n >= buf_.size() / 2) {  // large blocks go straight to the sink, in order
      flush();
      sink_(static_cast<const char*>(p), n);
      return;
    }
    reserve(n);
    std::memcpy(buf_.data() + pos_, p, n);
    pos_ += n;
  }
  void ch(char c) {
    reserve(1);
    buf_[pos_++] = c;
  }
  // Text numbers; the caller reserved room (32 bytes per number is always enough).
  template <class T>
  void num(T v) {
    reserve(32);
    auto r = std::to_chars(buf_.data() + pos_, buf_.data() + buf_.size(), v);
    pos_ = static_cast<size_t>(r.ptr - buf_.data());
  }
  template <class T>
  void bin(T v) {
    raw(&v, sizeof(T));
  }

 private:
  std::function<void(const char*, size_t)> sink_;
  std::vector<char> buf_;
  size_t pos_ = 0;
};

struct Entity {
  int tag = 1;
  std::vector<int> faces;
  std::vector<int> physicals;  // tags of the groups holding this entity
  double bbox[6] = {0, 0, 0, 0, 0, 0};
};

void validate(const HighOrderMesh& hm, const Eigen::MatrixXd& X) {
  const int p = hm.order;
  auto bad = [](const std::string& why) { throw InputError("HighOrderMesh", why); };
  if (p < 1 || p > 10) bad("order " + std::to_string(p) + " out of range 1..10");
  const Eigen::Index nf = hm.F.rows(), ne = hm.E.rows();
  if (nf > 0 && hm.F.cols() != 3) bad("F must have 3 columns");
  if (hm.V.rows() > 0 && hm.V.cols() != 3) bad("V must have 3 columns");
  if (hm.FE.rows() != nf || (nf > 0 && hm.FE.cols() != 3))
    bad("FE has " + std::to_string(hm.FE.rows()) + " rows for " + std::to_string(nf) + " faces");
  if (ne > 0 && hm.E.cols() != 2) bad("E must have 2 columns");
  if (hm.edge_nodes.rows() != ne * hm.nodes_per_edge())
    bad("edge_nodes has " + std::to_string(hm.edge_nodes.rows()) + " rows, expected " +
        std::to_string(ne * hm.nodes_per_edge()));
  if (hm.face_nodes.rows() != nf * hm.nodes_per_face())
    bad("face_nodes has " + std::to_string(hm.face_nodes.rows()) + " rows, expected " +
        std::to_string(nf * hm.nodes_per_face()));
  if (hm.face_entity.size() != 0 && hm.face_entity.size() != nf)
    bad("face_entity has " + std::to_string(hm.face_entity.size()) + " entries for " + std::to_string(nf) + " faces");
  for (Eigen::Index f = 0; f < nf; ++f) {
    for (int j = 0; j < 3; ++j) {
      if (hm.F(f, j) < 0 || hm.F(f, j) >= hm.V.rows())
        bad("face " + std::to_string(f) + ": vertex index " + std::to_string(hm.F(f, j)) + " out of range");
      const int e = hm.FE(f, j);
      if (e < 0 || e >= ne) bad("face " + std::to_string(f) + ": edge index " + std::to_string(e) + " out of range");
      const int a = hm.F(f, j), b = hm.F(f, (j + 1) % 3);
      if (!((hm.E(e, 0) == a && hm.E(e, 1) == b) || (hm.E(e, 0) == b && hm.E(e, 1) == a)))
        bad("face " + std::to_string(f) + ": edge " + std::to_string(e) + " does not join corners " +
            std::to_string(j) + " and " + std::to_string((j + 1) % 3));
    }
    if (hm.entity_of(static_cast<int>(f)) <= 0)
      bad("face " + std::to_string(f) + ": entity tag " + std::to_string(hm.entity_of(static_cast<int>(f))) +
          " must be positive");
  }
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    if (!std::isfinite(X(i, 0)) || !std::isfinite(X(i, 1)) || !std::isfinite(X(i, 2)))
      bad("node " + std::to_string(i + 1) + " has a non-finite coordinate");
  for (const PhysicalGroup& g : hm.physicals) {
    if (g.tag <= 0) bad("physical group '" + g.name + "' has non-positive tag " + std::to_string(g.tag));
    if (g.name.find_first_of("\"\n\r") != std::string::npos)
      bad("physical group " + std::to_string(g.tag) + " name contains a quote or newline");
  }
}

std::vector<Entity> collect_entities(const HighOrderMesh& hm, const Eigen::MatrixXd& X) {
  std::map<int, Entity> by_tag;
  const int n = triangle_node_count(hm.order);
  std::vector<int> idx(n);
  for (int f = 0; f < hm.num_faces(); ++f) {
    Entity& en = by_tag[hm.entity_of(f)];
    if (en.faces.empty()) {
      en.tag = hm.entity_of(f);
      for (int d = 0; d < 3; ++d) {
        en.bbox[d] = std::numeric_limits<double>::infinity();
        en.bbox[3 + d] = -std::numeric_limits<double>::infinity();
      }
    }
    en.faces.push_back(f);
    element_node_indices(hm, f, idx.data());
    for (int k = 0; k < n; ++k)
      for (int d = 0; d < 3; ++d) {
        en.bbox[d] = std::min(en.bbox[d], X(idx[k], d));
        en.bbox[3 + d] = std::max(en.bbox[3 + d], X(idx[k], d));
      }
  }
  if (by_tag.empty()) by_tag[1].tag = 1;  // an empty mesh still names one surface
  std::vector<Entity> out;
  for (auto& [tag, en] : by_tag) {
    std::set<int> phys;
    for (const PhysicalGroup& g : hm.physicals)
      if (std::find(g.entities.begin(), g.entities.end(), tag) != g.entities.end()) phys.insert(g.tag);
    en.physicals.assign(phys.begin(), phys.end());
    out.push_back(std::move(en));
  }
  return out;
}

void write_header(Out& o, const HighOrderMesh& hm, const MshOptions& opt) {
  const bool v41 = opt.version == MshOptions::Version::V41;
  o.str("$MeshFormat\n");
  o.str(v41 ? "4.1 " : "2.2 ");
  o.str(opt.binary ? "1 8\n" : "0 8\n");
  if (opt.binary) {
    o.bin<int32_t>(1);
    o.ch('\n');
  }
  o.str("$EndMeshFormat\n");
  if (opt.write_info) {
    o.str("$HocurveInfo\nnodes ");
    o.str(to_string(hm.distribution));
    o.str(" order ");
    o.num(hm.order);
    o.str(" generator hocurve\n$EndHocurveInfo\n");
  }
}

void write_physical_names(Out& o, const HighOrderMesh& hm) {
  int named = 0;
  for (const PhysicalGroup& g : hm.physicals) named += !g.name.empty();
  if (!named) return;
  o.str("$PhysicalNames\n");
  o.num(named);
  o.ch('\n');
  for (const PhysicalGroup& g : hm.physicals) {
    if (g.name.empty()) continue;
    o.str("2 ");
    o.num(g.tag);
    o.str(" \"");
    o.str(g.name);
    o.str("\"\n");
  }
  o.str("$EndPhysicalNames\n");
}

void write_entities_41(Out& o, const std::vector<Entity>& ents, bool binary) {
  o.str("$Entities\n");
  if (binary) {
    for (uint64_t c : {uint64_t(0), uint64_t(0), uint64_t(ents.size()), uint64_t(0)}) o.bin(c);
    for (const Entity& en : ents) {
      o.bin<int32_t>(en.tag);
      for (double b : en.bbox) o.bin(b);
      o.bin<uint64_t>(en.physicals.size());
      for (int t : en.physicals) o.bin<int32_t>(t);
      o.bin<uint64_t>(0);
    }
    o.ch('\n');
  } else {
    o.str("0 0 ");
    o.num(ents.size());
    o.str(" 0\n");
    for (const Entity& en : ents) {
      o.num(en.tag);
      for (double b : en.bbox) {
        o.ch(' ');
        o.num(b);
      }
      o.ch(' ');
      o.num(en.physicals.size());
      for (int t : en.physicals) {
        o.ch(' ');
        o.num(t);
      }
      o.str(" 0\n");
    }
  }
  o.str("$EndEntities\n");
}

// Formats items [0, n) as text in parallel chunks and appends them to o in order: a TBB
// pipeline with a bounded number of chunks in flight, so memory stays small and the bytes
// are identical to a serial loop. fmt(out, i) writes item i.
template <class Fmt>
void parallel_text(Out& o, size_t n, size_t chunk, const Fmt& fmt) {
  using Range = std::pair<size_t, size_t>;
  size_t next = 0;
  tbb::parallel_pipeline(
      8,
      tbb::make_filter<void, Range>(tbb::filter_mode::serial_in_order,
                                    [&](tbb::flow_control& fc) {
                                      if (next >= n) {
                                        fc.stop();
                                        return Range{};
                                      }
                                      const Range r{next, std::min(n, next + chunk)};
                                      next = r.second;
                                      return r;
                                    }) &
          tbb::make_filter<Range, std::string>(tbb::filter_mode::parallel,
                                               [&](Range r) {
                                                 std::string s;
                                                 Out t([&](const char* p, size_t k) { s.append(p, k); },
                                                       size_t(1) << 16);
                                                 for (size_t i = r.first; i < r.second; ++i) fmt(t, i);
                                                 t.flush();
                                                 return s;
                                               }) &
          tbb::make_filter<std::string, void>(tbb::filter_mode::serial_in_order,
                                              [&](const std::string& s) { o.raw(s.data(), s.size()); }));
}

void write_coords_text(Out& o, const Eigen::MatrixXd& X, Eigen::Index i) {
  o.reserve(80);
  o.num(X(i, 0));
  o.ch(' ');
  o.num(X(i, 1));
  o.ch(' ');
  o.num(X(i, 2));
  o.ch('\n');
}

void write_nodes_41(Out& o, const Eigen::MatrixXd& X, int entity, bool binary) {
  const uint64_t n = static_cast<uint64_t>(X.rows());
  const uint64_t nblocks = n ? 1 : 0;
  o.str("$Nodes\n");
  if (binary) {
    for (uint64_t c : {nblocks, n, n ? uint64_t(1) : uint64_t(0), n}) o.bin(c);
    if (n) {
      for (int32_t c : {int32_t(2), int32_t(entity), int32_t(0)}) o.bin(c);
      o.bin<uint64_t>(n);
      for (uint64_t t = 1; t <= n; ++t) o.bin(t);
      for (Eigen::Index i = 0; i < X.rows(); ++i) {
        const double xyz[3] = {X(i, 0), X(i, 1), X(i, 2)};
        o.raw(xyz, sizeof xyz);
      }
    }
    o.ch('\n');
  } else {
    o.num(nblocks);
    o.ch(' ');
    o.num(n);
    o.str(n ? " 1 " : " 0 ");
    o.num(n);
    o.ch('\n');
    if (n) {
      o.str("2 ");
      o.num(entity);
      o.str(" 0 ");
      o.num(n);
      o.ch('\n');
      for (uint64_t t = 1; t <= n; ++t) {
        o.num(t);
        o.ch('\n');
      }
      parallel_text(o, static_cast<size_t>(X.rows()), 16384,
                    [&](Out& t, size_t i) { write_coords_text(t, X, static_cast<Eigen::Index>(i)); });
    }
  }
  o.str("$EndNodes\n");
}

void write_elements_41(Out& o, const HighOrderMesh& hm, const std::vector<Entity>& ents, bool binary) {
  const int type = gmsh_triangle_type(hm.order), n = triangle_node_count(hm.order);
  const uint64_t nf = static_cast<uint64_t>(hm.num_faces());
  uint64_t nblocks = 0;
  for (const Entity& en : ents) nblocks += !en.faces.empty();
  std::vector<int> idx(n);
  o.str("$Elements\n");
  if (binary) {
    for (uint64_t c : {nblocks, nf, nf ? uint64_t(1) : uint64_t(0), nf}) o.bin(c);
    std::vector<uint64_t> rec(n + 1);
    for (const Entity& en : ents) {
      if (en.faces.empty()) continue;
      for (int32_t c : {int32_t(2), int32_t(en.tag), int32_t(type)}) o.bin(c);
      o.bin<uint64_t>(en.faces.size());
      for (int f : en.faces) {
        element_node_indices(hm, f, idx.data());
        rec[0] = static_cast<uint64_t>(f) + 1;
        for (int k = 0; k < n; ++k) rec[k + 1] = static_cast<uint64_t>(idx[k]) + 1;
        o.raw(rec.data(), rec.size() * sizeof(uint64_t));
      }
    }
    o.ch('\n');
  } else {
    o.num(nblocks);
    o.ch(' ');
    o.num(nf);
    o.str(nf ? " 1 " : " 0 ");
    o.num(nf);
    o.ch('\n');
    for (const Entity& en : ents) {
      if (en.faces.empty()) continue;
      o.str("2 ");
      o.num(en.tag);
      o.ch(' ');
      o.num(type);
      o.ch(' ');
      o.num(en.faces.size());
      o.ch('\n');
      parallel_text(o, en.faces.size(), 8192, [&](Out& t, size_t i) {
        int local[66];
        const int f = en.faces[i];
        element_node_indices(hm, f, local);
        t.reserve(static_cast<size_t>(n + 1) * 24);
        t.num(f + 1);
        for (int k = 0; k < n; ++k) {
          t.ch(' ');
          t.num(local[k] + 1);
        }
        t.ch('\n');
      });
    }
  }
  o.str("$EndElements\n");
}

void write_nodes_22(Out& o, const Eigen::MatrixXd& X, bool binary) {
  o.str("$Nodes\n");
  o.num(X.rows());
  o.ch('\n');
  if (binary) {
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      o.bin<int32_t>(static_cast<int32_t>(i + 1));
      const double xyz[3] = {X(i, 0), X(i, 1), X(i, 2)};
      o.raw(xyz, sizeof xyz);
    }
  } else {
    parallel_text(o, static_cast<size_t>(X.rows()), 16384, [&](Out& t, size_t i) {
      t.num(i + 1);
      t.ch(' ');
      write_coords_text(t, X, static_cast<Eigen::Index>(i));
    });
  }
  if (binary) o.ch('\n');
  o.str("$EndNodes\n");
}

void write_elements_22(Out& o, const HighOrderMesh& hm, const std::vector<Entity>& ents, bool binary) {
  const int type = gmsh_triangle_type(hm.order), n = triangle_node_count(hm.order);
  // One copy of an entity's elements per physical group (physical 0 when it has none).
  long long total = 0;
  for (const Entity& en : ents)
    total += static_cast<long long>(en.faces.size()) * std::max<size_t>(1, en.physicals.size());
  std::vector<int> idx(n);
  std::vector<int32_t> rec(n + 3);
  o.str("$Elements\n");
  o.num(total);
  o.ch('\n');
  // Element tag = face + 1 for an element's first copy (as in 4.1); further copies (entities
  // in several groups) are numbered after the last face.
  long long extra = hm.num_faces();
  for (const Entity& en : ents) {
    const std::vector<int> phys = en.physicals.empty() ? std::vector<int>{0} : en.physicals;
    for (size_t q = 0; q < phys.size(); ++q) {
      const int ph = phys[q];
      const long long first = extra + 1;  // tag of copy i when q > 0: first + i
      auto tag_of = [&](size_t i) { return q == 0 ? static_cast<long long>(en.faces[i]) + 1 : first + static_cast<long long>(i); };
      if (binary && !en.faces.empty()) {
        for (int32_t c : {int32_t(type), int32_t(en.faces.size()), int32_t(2)}) o.bin(c);
      }
      if (binary) {
        for (size_t i = 0; i < en.faces.size(); ++i) {
          element_node_indices(hm, en.faces[i], idx.data());
          rec[0] = static_cast<int32_t>(tag_of(i));
          rec[1] = ph;
          rec[2] = en.tag;
          for (int k = 0; k < n; ++k) rec[k + 3] = idx[k] + 1;
          o.raw(rec.data(), rec.size() * sizeof(int32_t));
        }
      } else {
        parallel_text(o, en.faces.size(), 8192, [&](Out& t, size_t i) {
          int local[66];
          element_node_indices(hm, en.faces[i], local);
          t.reserve(static_cast<size_t>(n + 5) * 24);
          t.num(tag_of(i));
          t.ch(' ');
          t.num(type);
          t.str(" 2 ");
          t.num(ph);
          t.ch(' ');
          t.num(en.tag);
          for (int k = 0; k < n; ++k) {
            t.ch(' ');
            t.num(local[k] + 1);
          }
          t.ch('\n');
        });
      }
      if (q > 0) extra += static_cast<long long>(en.faces.size());
    }
  }
  if (binary) o.ch('\n');
  o.str("$EndElements\n");
}

void write_all(const HighOrderMesh& hm, const MshOptions& opt, const std::function<void(const char*, size_t)>& sink) {
  const Eigen::MatrixXd X = all_nodes(hm);
  validate(hm, X);
  const std::vector<Entity> ents = collect_entities(hm, X);
  const bool v41 = opt.version == MshOptions::Version::V41;
  const bool with_entities = !hm.physicals.empty() || ents.size() > 1;
  if (!v41 && opt.binary) {
    long long elements = 0;
    for (const Entity& en : ents)
      elements += static_cast<long long>(en.faces.size()) * std::max<size_t>(1, en.physicals.size());
    if (std::max<long long>(X.rows(), elements) > std::numeric_limits<int32_t>::max())
      throw InputError("HighOrderMesh", "too many nodes or elements for MSH 2.2 binary (int32 tags)");
  }
  Out o(sink);
  write_header(o, hm, opt);
  if (with_entities) write_physical_names(o, hm);
  if (v41) {
    if (with_entities) write_entities_41(o, ents, opt.binary);
    write_nodes_41(o, X, ents.front().tag, opt.binary);
    write_elements_41(o, hm, ents, opt.binary);
  } else {
    write_nodes_22(o, X, opt.binary);
    write_elements_22(o, hm, ents, opt.binary);
  }
  o.flush();
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

void write_msh(const HighOrderMesh& hm, std::ostream& os, const MshOptions& opt) {
  write_all(hm, opt, [&](const char* p, size_t n) {
    os.write(p, static_cast<std::streamsize>(n));
    if (!os) throw std::runtime_error("write_msh: output stream failed");
  });
  os.flush();
  if (!os) throw std::runtime_error("write_msh: output stream failed");
}

std::string write_msh_string(const HighOrderMesh& hm, const MshOptions& opt) {
  std::string s;
  // Rough size (exact for binary 4.1 up to the headers) to avoid repeated regrowth.
  const size_t nodes = static_cast<size_t>(hm.V.rows() + hm.edge_nodes.rows() + hm.face_nodes.rows());
  s.reserve(nodes * 32 + static_cast<size_t>(hm.num_faces()) * (triangle_node_count(std::clamp(hm.order, 1, 10)) + 1) * 8 + 4096);
  write_all(hm, opt, [&](const char* p, size_t n) { s.append(p, n); });
  return s;
}

void write_msh_file(const HighOrderMesh& hm, const std::string& path, const MshOptions& opt) {
  write_file_atomically(path, [&](const ByteSink& sink) { write_all(hm, opt, sink); });
}

void write_file_atomically(const std::string& path, const std::function<void(const ByteSink&)>& produce) {
  // Temporary next to the target (same file system, so rename is atomic); O_EXCL with a
  // random suffix instead of mkstemp so the final file gets the usual 0666 & ~umask mode.
  std::random_device rd;
  std::string tmp;
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    std::ostringstream name;
    name << path << ".tmp." << std::hex << rd() << rd();
    tmp = name.str();
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) throw std::runtime_error(path + ": cannot create temporary file: " + errno_text());
  }
  if (fd < 0) throw std::runtime_error(path + ": cannot create a unique temporary file");
  try {
    produce([&](const char* p, size_t n) {
      while (n > 0) {
        const ssize_t w = ::write(fd, p, n);
        if (w < 0) {
          if (errno == EINTR) continue;
          throw std::runtime_error(path + ": write failed: " + errno_text());
        }
        p += w;
        n -= static_cast<size_t>(w);
      }
    });
    if (::fsync(fd) != 0) throw std::runtime_error(path + ": fsync failed: " + errno_text());
    const int rc = ::close(fd);
    fd = -1;
    if (rc != 0) throw std::runtime_error(path + ": close failed: " + errno_text());
    if (::rename(tmp.c_str(), path.c_str()) != 0) throw std::runtime_error(path + ": rename failed: " + errno_text());
  } catch (...) {
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  // Make the rename itself durable; failure here does not invalidate the complete file.
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace hocurve
