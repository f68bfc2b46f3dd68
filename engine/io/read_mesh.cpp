#include "engine/io/read_mesh.hpp"

#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"
#include "engine/io/weld_vertices.hpp"

#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

namespace hocurve {
namespace {

bool is_gzip(std::string_view b) {
  return b.size() >= 2 && static_cast<unsigned char>(b[0]) == 0x1f && static_cast<unsigned char>(b[1]) == 0x8b;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// The name's extension without a trailing ".gz", lower case ("stl", "obj", ...).
std::string extension_hint(const std::string& name) {
  std::string n = lower(name);
  if (ends_with(n, ".gz")) n.resize(n.size() - 3);
  const auto dot = n.find_last_of('.');
  const auto slash = n.find_last_of("/\\");
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  return n.substr(dot + 1);
}

std::string_view skip_space(std::string_view b) {
  std::size_t i = 0;
  // A UTF-8 byte order mark sometimes precedes text formats.
  if (b.size() >= 3 && b.substr(0, 3) == "\xEF\xBB\xBF") i = 3;
  while (i < b.size() && std::isspace(static_cast<unsigned char>(b[i]))) ++i;
  return b.substr(i);
}

bool starts_with_word(std::string_view b, std::string_view w) {
  if (b.size() < w.size()) return false;
  for (std::size_t i = 0; i < w.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(b[i])) != w[i]) return false;
  return b.size() == w.size() || std::isspace(static_cast<unsigned char>(b[w.size()])) || b[w.size()] == '\0';
}

bool looks_like_text(std::string_view b) {
  for (unsigned char c : b)
    if (c < 9 || (c > 13 && c < 32) || c == 127) return false;
  return true;
}

bool looks_like_obj(std::string_view head) {
  // Every non-empty, non-comment line must start with a known OBJ keyword, and one must be "v".
  // The head is at most 64 KiB: no line limit, so a long comment header or many group lines
  // before the first "v" do not hide an OBJ.
  bool saw_v = false;
  std::size_t pos = 0;
  while (pos < head.size()) {
    std::size_t end = head.find('\n', pos);
    const bool complete = end != std::string_view::npos;
    if (!complete) end = head.size();
    std::string_view line = skip_space(head.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty() || line[0] == '#') continue;
    if (!complete) break;  // the last, cut line of a partial head proves nothing
    static constexpr std::string_view keys[] = {"v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "usemtl",
                                                "mtllib", "cstype", "deg", "curv", "parm", "end", "surf"};
    bool ok = false;
    for (auto k : keys)
      if (starts_with_word(line, k)) ok = true;
    if (!ok) return false;
    if (starts_with_word(line, "v")) saw_v = true;
  }
  return saw_v;
}

std::uint32_t stl_declared_count(std::string_view b) {
  std::uint32_t n = 0;
  std::memcpy(&n, b.data() + 80, 4);
  return n;
}

/// Format detection on the (inflated) content; total_size is the full inflated size when known.
std::string detect_plain(std::string_view b, std::size_t total_size, const std::string& name) {
  const std::string_view t = skip_space(b);
  if (t.substr(0, 11) == "$MeshFormat") {
    std::string_view rest = skip_space(t.substr(11));
    return rest.substr(0, 1) == "2" ? "msh2" : "msh4";
  }
  if (t.substr(0, 3) == "ply" && t.size() > 3 && (t[3] == '\n' || t[3] == '\r')) {
    const auto nl = t.find("format");
    if (nl != std::string_view::npos && t.substr(nl, 13) == "format binary") return "ply-binary";
    return "ply-ascii";
  }
  for (std::string_view k : {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCOFF", "STNOFF", "NCOFF"})
    if (t.substr(0, k.size()) == k &&
        (t.size() == k.size() || std::isspace(static_cast<unsigned char>(t[k.size()]))))
      return "off";
  const std::string ext = extension_hint(name);
  const bool has_stl_size = total_size >= 84 && b.size() >= 84;
  if (has_stl_size && 84 + 50ull * stl_declared_count(b) == total_size) return "stl-binary";
  if (starts_with_word(t, "solid")) {
    const std::string_view head = t.substr(0, 4096);
    if (looks_like_text(head) && (head.find("facet") != std::string_view::npos ||
                                  head.find("endsolid") != std::string_view::npos))
      return "stl-ascii";
  }
  if (looks_like_text(b.substr(0, 65536)) && looks_like_obj(b.substr(0, 65536))) return "obj";
  // Binary STL with data after the declared facets, or truncated: only trusted with a .stl name
  // or when the declared facets fit in the file (garbage rarely declares a fitting count).
  if (has_stl_size) {
    const std::uint32_t n = stl_declared_count(b);
    if (n > 0 && 84 + 50ull * n <= total_size && !looks_like_text(b.substr(0, 84 + 50ull * std::min(n, 20u))))
      return "stl-binary";
  }
  if (ext == "stl" && !starts_with_word(t, "solid")) return "stl-binary";
  if (ext == "stl") return "stl-ascii";
  return {};
}

}  // namespace

std::string gunzip(std::string_view bytes, const std::string& name) {
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw InputError(name, "cannot initialise zlib");
  std::unique_ptr<z_stream, int (*)(z_stream*)> guard(&zs, inflateEnd);
  std::string out;
  // The gzip trailer holds the inflated size modulo 2^32: a good first guess.
  std::size_t guess = bytes.size() * 4;
  if (is_gzip(bytes) && bytes.size() >= 18) {
    std::uint32_t isize = 0;
    std::memcpy(&isize, bytes.data() + bytes.size() - 4, 4);
    // Deflate cannot exceed ~1032:1; a corrupt trailer must not make us allocate gigabytes.
    if (isize > 0) guess = std::min<std::size_t>(isize, bytes.size() * 1032);
  }
  guess = std::min<std::size_t>(guess, std::size_t(1) << 28);  // beyond that, grow by doubling
  out.resize(std::max<std::size_t>(guess, 1024));
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  std::size_t in_left = bytes.size(), produced = 0;
  for (;;) {
    if (produced == out.size()) out.resize(out.size() * 2);
    const uInt in_chunk = static_cast<uInt>(std::min<std::size_t>(in_left, 1u << 30));
    const uInt out_chunk = static_cast<uInt>(std::min<std::size_t>(out.size() - produced, 1u << 30));
    zs.avail_in = in_chunk;
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    zs.avail_out = out_chunk;
    const int rc = inflate(&zs, Z_NO_FLUSH);
    in_left -= in_chunk - zs.avail_in;
    produced += out_chunk - zs.avail_out;
    if (rc == Z_STREAM_END) {
      // Concatenated gzip members are legal: continue when another one follows.
      if (in_left >= 2 && is_gzip(std::string_view(reinterpret_cast<const char*>(zs.next_in), in_left))) {
        inflateReset(&zs);
        continue;
      }
      break;
    }
    if (rc == Z_BUF_ERROR && in_left == 0)
      throw InputError(name, "truncated gzip stream (" + std::to_string(produced) + " bytes inflated)");
    if (rc != Z_OK && rc != Z_BUF_ERROR)
      throw InputError(name, std::string("corrupt gzip stream: ") + (zs.msg ? zs.msg : "inflate error"));
  }
  out.resize(produced);
  return out;
}

std::string detect_format(std::string_view bytes, const std::string& name) {
  if (!is_gzip(bytes)) return detect_plain(bytes, bytes.size(), name);
  // Inflate only the head; the gzip trailer (ISIZE) gives the full size for the binary STL test.
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) return {};
  std::string head(65536, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  zs.avail_in = static_cast<uInt>(std::min<std::size_t>(bytes.size(), 1u << 30));
  zs.next_out = reinterpret_cast<Bytef*>(head.data());
  zs.avail_out = static_cast<uInt>(head.size());
  const int rc = inflate(&zs, Z_SYNC_FLUSH);
  head.resize(head.size() - zs.avail_out);
  inflateEnd(&zs);
  if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR) return {};
  std::size_t total = head.size();
  if (rc != Z_STREAM_END && bytes.size() >= 18) {
    std::uint32_t isize = 0;
    std::memcpy(&isize, bytes.data() + bytes.size() - 4, 4);
    total = isize;
  }
  return detect_plain(head, total, name);
}

namespace io_detail {
void check_finite_vertices(const Mesh& mesh, const std::string& name, bool from_one) {
  static constexpr const char* axis[] = {"x", "y", "z"};
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(mesh.V(v, d)))
        throw InputError(name, "vertex " + std::to_string(v + from_one) + (from_one ? " (counting from 1)" : "") + " has " +
                                   (std::isnan(mesh.V(v, d)) ? "a NaN" : "an infinite") + " " + axis[d] +
                                   " coordinate");
}
}  // namespace io_detail

namespace {

/// Whether every face index of m names a vertex (else validate_mesh names the bad one).
bool indices_in_range(const Mesh& m) {
  return !m.F.size() || (m.F.minCoeff() >= 0 && m.F.maxCoeff() < m.V.rows());
}

/// Replaces the mesh's vertices by V and face indices i by to_new[i]; warns "name: N<what>".
void merge_vertices(ReadResult& out, Eigen::MatrixXd V, const std::vector<int>& to_new, const std::string& name,
                    const std::string& what) {
  Mesh& m = out.mesh;
  const Eigen::Index merged = m.V.rows() - V.rows();
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int j = 0; j < 3; ++j) m.F(f, j) = to_new[static_cast<std::size_t>(m.F(f, j))];
  m.V = std::move(V);
  out.report.welded_vertices += merged;
  out.report.warnings.push_back(name + ": " + std::to_string(merged) + what);
}

/// Indexed formats may still repeat a position under several indices (per-face exports, meshes
/// assembled from parts): those faces would not share their edges, and every such seam would
/// be curved as two open boundaries. Merges exactly equal positions, as STL reading does.
void weld_repeated_positions(ReadResult& out, const std::string& name) {
  const Mesh& m = out.mesh;
  const Eigen::Index n = m.V.rows();
  if (!indices_in_range(m)) return;
  std::vector<double> xyz(static_cast<std::size_t>(3 * n));
  for (Eigen::Index i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) xyz[static_cast<std::size_t>(3 * i + k)] = m.V(i, k);
  WeldResult<double> w = weld_exact(xyz.data(), static_cast<std::size_t>(n));
  const Eigen::Index nu = static_cast<Eigen::Index>(w.points.size() / 3);
  if (nu == n) return;
  Eigen::MatrixXd V(nu, 3);
  for (Eigen::Index i = 0; i < nu; ++i)
    for (int k = 0; k < 3; ++k) V(i, k) = w.points[static_cast<std::size_t>(3 * i + k)];
  merge_vertices(out, std::move(V), w.index, name,
                 " vertices repeat another vertex's exact position and were merged with it");
}

/// Merges vertices within rel x the used vertices' bounding-box diagonal of each other (weld_within), keeping the
/// lowest-numbered one's position.
void weld_near_positions(ReadResult& out, const std::string& name, double rel) {
  const Mesh& m = out.mesh;
  const Eigen::Index n = m.V.rows();
  if (n == 0 || m.F.rows() == 0 || !indices_in_range(m)) return;
  // The box of the vertices faces use: unreferenced far ones (validate_mesh drops them) made the
  // tolerance so large that every used vertex merged into one.
  Eigen::RowVector3d lo = m.V.row(m.F(0, 0)), hi = lo;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int j = 0; j < 3; ++j) {
      lo = lo.cwiseMin(m.V.row(m.F(f, j)));
      hi = hi.cwiseMax(m.V.row(m.F(f, j)));
    }
  const double tol = rel * (hi - lo).stableNorm();
  if (!std::isfinite(tol)) return;  // a box beyond double range: validate_mesh refuses it
  std::vector<int> to_new = weld_within(m.V, tol);  // each vertex's root, then the root's new index
  std::vector<int> kept;
  for (Eigen::Index i = 0; i < n; ++i)
    if (to_new[static_cast<std::size_t>(i)] == i) kept.push_back(static_cast<int>(i));
  if (static_cast<Eigen::Index>(kept.size()) == n) return;
  std::vector<int> new_of_root(static_cast<std::size_t>(n), -1);
  Eigen::MatrixXd V(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    new_of_root[static_cast<std::size_t>(kept[k])] = static_cast<int>(k);
    V.row(static_cast<Eigen::Index>(k)) = m.V.row(kept[k]);
  }
  for (int& r : to_new) r = new_of_root[static_cast<std::size_t>(r)];
  char buf[160];
  std::snprintf(buf, sizeof buf, " vertices lie within %.3g (%g of the bounding-box diagonal) of another and were merged with it",
                tol, rel);
  merge_vertices(out, std::move(V), to_new, name, buf);
}

}  // namespace

ReadResult read_mesh_bytes(std::string_view bytes, const std::string& name, const ReadOptions& opt) {
  ReadResult out;
  std::string inflated;
  if (is_gzip(bytes)) {
    inflated = gunzip(bytes, name);
    bytes = inflated;
    out.report.gzip = true;
  }
  if (bytes.empty()) throw InputError(name, out.report.gzip ? "empty file (after gunzip)" : "empty file");
  if (skip_space(bytes).empty()) throw InputError(name, "file holds only white space");
  const std::string fmt = detect_plain(bytes, bytes.size(), name);
  if (fmt.empty())
    throw InputError(name, "unknown mesh format (expected STL, OBJ, PLY, OFF or Gmsh .msh, optionally gzip)");
  out.report.format = fmt;
  if (fmt == "stl-binary") io_detail::read_stl_binary(bytes, name, opt, out);
  else if (fmt == "stl-ascii") io_detail::read_stl_ascii(bytes, name, opt, out);
  else if (fmt == "obj") io_detail::read_obj(bytes, name, out);
  else if (fmt == "ply-ascii" || fmt == "ply-binary") io_detail::read_ply(bytes, name, out);
  else if (fmt == "off") io_detail::read_off(bytes, name, out);
  else io_detail::read_msh(bytes, name, out);
  if (out.mesh.F.rows() == 0) throw InputError(name, "no triangles in the file");
  io_detail::check_finite_vertices(out.mesh, name, fmt == "obj");
  if (opt.weld && fmt != "stl-binary" && fmt != "stl-ascii") weld_repeated_positions(out, name);
  if (opt.weld && opt.weld_tolerance > 0) weld_near_positions(out, name, opt.weld_tolerance);
  out.report.facets_read = out.mesh.F.rows();
  return out;
}

ReadResult read_mesh_file(const std::string& path, const ReadOptions& opt) {
  // A directory opens as a file of unbounded size, a device (/dev/zero) never ends: refused by
  // kind. Pipes and FIFOs (`<(gunzip -c m.stl.gz)`) are read to their end.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw InputError(path, "is a directory, not a mesh file");
    if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) throw InputError(path, "is a device, not a mesh file");
  }
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), std::fclose);
  if (!f) throw InputError(path, std::string("cannot open file: ") + std::strerror(errno));
  std::string data;
  if (std::fseek(f.get(), 0, SEEK_END) == 0) {
    const long size = std::ftell(f.get());
    if (size > 0) data.resize(static_cast<std::size_t>(size));
    std::fseek(f.get(), 0, SEEK_SET);
  }
  std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f.get());
  data.resize(got);
  // Pipes and special files report no size: read on until EOF.
  char buf[65536];
  std::size_t k;
  while ((k = std::fread(buf, 1, sizeof buf, f.get())) > 0) data.append(buf, k);
  if (std::ferror(f.get())) throw InputError(path, "read error");
  return read_mesh_bytes(data, path, opt);
}

}  // namespace hocurve
