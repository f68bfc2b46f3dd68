// Wavefront OBJ through Debian's tinyobjloader (double build), parsed from memory.
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"

#include <tiny_obj_loader.h>

#include <charconv>
#include <cstdlib>
#include <istream>
#include <streambuf>

namespace hocurve::io_detail {
namespace {

/// Read-only streambuf over memory, so tinyobjloader reads without a copy of the file.
struct MemoryBuf : std::streambuf {
  MemoryBuf(const char* b, std::size_t n) {
    char* p = const_cast<char*>(b);
    setg(p, p, p + n);
  }
};

/// Materials are irrelevant for geometry: never open .mtl files.
struct NoMaterials : tinyobj::MaterialReader {
  bool operator()(const std::string&, std::vector<tinyobj::material_t>*, std::map<std::string, int>*,
                  std::string*, std::string*) override {
    return true;
  }
};

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// True when the line of b from q (its first non-blank) to e starts with keyword c ("v", "f").
bool keyword(std::string_view b, std::size_t q, std::size_t e, char c) { return q + 1 < e && b[q] == c && blank(b[q + 1]); }

/// Calls f(line number, first non-blank position, end of line) for each line of b.
template <class F>
void for_each_line(std::string_view b, F f) {
  long long line = 0;
  for (std::size_t p = 0; p < b.size();) {
    std::size_t e = b.find('\n', p);
    if (e == std::string_view::npos) e = b.size();
    std::size_t q = p;
    while (q < e && blank(b[q])) ++q;
    f(++line, q, e);
    p = e + 1;
  }
}

/// tinyobjloader's number parser can be one ulp off (it reads "1.75" as 1.7500000000000002), and
/// it reads a coordinate that is not a number, or a missing one, as 0. Re-reads the "v" lines with
/// std::from_chars (correctly rounded) and refuses such lines; keeps tinyobjloader's values if the
/// two disagree on the vertex count.
void reread_vertices(std::string_view b, const std::string& name, std::vector<tinyobj::real_t>& xyz) {
  std::vector<double> out;
  out.reserve(xyz.size());
  for_each_line(b, [&](long long line, std::size_t q, std::size_t e) {
    if (!keyword(b, q, e, 'v')) return;
    q += 2;
    for (int d = 0; d < 3; ++d) {
      while (q < e && blank(b[q])) ++q;
      std::size_t t = q;
      while (t < e && !blank(b[t])) ++t;
      const std::string_view tok = b.substr(q, t - q);
      double v = 0;
      const char* first = tok.data() + (!tok.empty() && tok[0] == '+' ? 1 : 0);
      auto [r, ec] = std::from_chars(first, tok.data() + tok.size(), v);
      if (tok.empty() || (ec != std::errc() && ec != std::errc::result_out_of_range) || r != tok.data() + tok.size()) {
        std::string shown;  // printable, and short
        for (char c : tok.substr(0, 24)) shown += (c >= 0x20 && c < 0x7f) ? c : '?';
        throw InputError(name + ": line " + std::to_string(line),
                         tok.empty() ? "vertex has " + std::to_string(d) + " coordinates (x y z expected)"
                                     : "vertex coordinate '" + shown + "' is not a number");
      }
      if (ec == std::errc::result_out_of_range) v = std::strtod(std::string(tok).c_str(), nullptr);  // +-inf or 0
      out.push_back(v);  // non-finite values are refused with the vertex's number later
      q = t;
    }
  });
  if (out.size() == xyz.size()) std::copy(out.begin(), out.end(), xyz.begin());
}

/// tinyobjloader reads face indices into int without overflow checks (2^32 + 3 became vertex 3)
/// and names a bad one without its line. Checks every "f" line's vertex indices first: nonzero,
/// at most the file's vertex count, negatives at most the vertices read so far.
void check_face_indices(std::string_view b, const std::string& name) {
  long long total = 0, vertices = 0;
  for_each_line(b, [&](long long, std::size_t q, std::size_t e) { total += keyword(b, q, e, 'v'); });
  for_each_line(b, [&](long long line, std::size_t q, std::size_t e) {
    vertices += keyword(b, q, e, 'v');
    if (keyword(b, q, e, 'f')) {
      for (q += 2;;) {
        while (q < e && blank(b[q])) ++q;
        if (q >= e || b[q] == '#') break;
        std::size_t t = q;
        while (t < e && !blank(b[t]) && b[t] != '/') ++t;
        const std::string_view tok = b.substr(q, t - q);
        long long v = 0;
        auto [r, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
        const bool whole = ec == std::errc() && r == tok.data() + tok.size();
        if (!whole || v == 0 || v > total || v < -vertices)
          throw InputError(name + ": line " + std::to_string(line),
                           "face vertex index " + std::string(tok.substr(0, 24)) +
                               (whole || ec == std::errc::result_out_of_range
                                    ? " out of range (the file has " + std::to_string(total) +
                                          " vertices; OBJ counts from 1, negatives back from the last one read)"
                                    : " is not an integer"));
        while (t < e && !blank(b[t])) ++t;
        q = t;
      }
    }
  });
}

std::string first_line(const std::string& s) {
  std::string t = s.substr(0, s.find('\n'));
  return t.empty() ? "parse error" : t;
}

}  // namespace

void read_obj(std::string_view bytes, const std::string& name, ReadResult& out) {
  MemoryBuf buf(bytes.data(), bytes.size());
  std::istream in(&buf);
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  NoMaterials no_mtl;
  check_face_indices(bytes, name);
  // triangulate=false: we fan-split polygons ourselves, so the rule is ours and documented.
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, &no_mtl, false, false);
  if (!ok) throw InputError(name, "OBJ: " + first_line(err));
  reread_vertices(bytes, name, attrib.vertices);
  Mesh& m = out.mesh;
  const std::size_t nv = attrib.vertices.size() / 3;
  if (nv > static_cast<std::size_t>(INT32_MAX)) throw InputError(name, "too many vertices");
  m.V.resize(static_cast<Eigen::Index>(nv), 3);
  for (std::size_t v = 0; v < nv; ++v)
    for (int d = 0; d < 3; ++d) m.V(v, d) = static_cast<double>(attrib.vertices[3 * v + d]);
  std::vector<int> tri;
  std::vector<long long> poly;
  long long face = 0, polygons = 0, small = 0, points_lines = 0;
  for (const auto& sh : shapes) {
    std::size_t k = 0;
    for (const auto nfv : sh.mesh.num_face_vertices) {
      const int n = static_cast<int>(nfv);
      for (int c = 0; c < n; ++c) {
        const int vi = sh.mesh.indices[k + c].vertex_index;
        if (vi < 0 || static_cast<std::size_t>(vi) >= nv)
          throw InputError(name + ": face " + std::to_string(face),
                           "vertex index " + std::to_string(vi >= 0 ? vi + 1 : vi) +
                               " out of range (the file has " + std::to_string(nv) + " vertices; OBJ counts from 1)");
      }
      if (n < 3) ++small;
      if (n > 3) ++polygons;
      poly.clear();
      for (int c = 0; c < n; ++c) poly.push_back(sh.mesh.indices[k + c].vertex_index);
      split_polygon(m.V, poly, tri);
      k += n;
      ++face;
    }
    points_lines += static_cast<long long>(sh.lines.num_line_vertices.size() + sh.points.indices.size());
  }
  m.F.resize(static_cast<Eigen::Index>(tri.size() / 3), 3);
  for (std::size_t f = 0; f < tri.size() / 3; ++f)
    for (int j = 0; j < 3; ++j) m.F(f, j) = tri[3 * f + j];
  if (polygons) out.report.warnings.push_back(polygons_warning(name, polygons));
  if (small) out.report.warnings.push_back(name + ": " + std::to_string(small) + " faces with fewer than 3 corners ignored");
  if (points_lines) out.report.warnings.push_back(name + ": " + std::to_string(points_lines) + " point/line elements ignored");
}

}  // namespace hocurve::io_detail
