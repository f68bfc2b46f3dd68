// Wavefront OBJ: "v" and "f" lines, parsed here. Debian's tinyobjloader was dropped: it counts a
// face's corners in an unsigned char (a 1000-gon became 230 triangles and shifted every later
// face), reads indices into int unchecked (2^32 + 3 became vertex 3), reads a non-number
// coordinate as 0 and rounds some coordinates one ulp off.
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"

#include <charconv>
#include <cstdint>
#include <cstdlib>

namespace hocurve::io_detail {
namespace {

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

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

/// The keyword of the line of b from q (its first non-blank) to e: "v", "f", "vt", ...
std::string_view keyword(std::string_view b, std::size_t q, std::size_t e) {
  std::size_t t = q;
  while (t < e && !blank(b[t])) ++t;
  return b.substr(q, t - q);
}

/// Printable and short, for messages.
std::string shown(std::string_view tok) {
  std::string s;
  for (char c : tok.substr(0, 24)) s += (c >= 0x20 && c < 0x7f) ? c : '?';
  return s;
}

/// The x y z of a "v" line from q (after the keyword); w and colours after them are ignored.
/// Correctly rounded (std::from_chars); a missing or non-numeric coordinate is refused.
void read_vertex(std::string_view b, std::size_t q, std::size_t e, const std::string& where, double xyz[3]) {
  for (int d = 0; d < 3; ++d) {
    while (q < e && blank(b[q])) ++q;
    std::size_t t = q;
    while (t < e && !blank(b[t])) ++t;
    const std::string_view tok = b.substr(q, t - q);
    if (tok.empty()) throw InputError(where, "vertex has " + std::to_string(d) + " coordinates (x y z expected)");
    double v = 0;
    const char* first = tok.data() + (tok[0] == '+' ? 1 : 0);
    auto [r, ec] = std::from_chars(first, tok.data() + tok.size(), v);
    if ((ec != std::errc() && ec != std::errc::result_out_of_range) || r != tok.data() + tok.size())
      throw InputError(where, "vertex coordinate '" + shown(tok) + "' is not a number");
    if (ec == std::errc::result_out_of_range) v = std::strtod(std::string(tok).c_str(), nullptr);  // +-inf or 0
    xyz[d] = v;  // non-finite values are refused with the vertex's number later
    q = t;
  }
}

}  // namespace

void read_obj(std::string_view b, const std::string& name, ReadResult& out) {
  // Positive indices may name vertices defined further down: count them all first.
  long long total = 0;
  for_each_line(b, [&](long long, std::size_t q, std::size_t e) { total += keyword(b, q, e) == "v"; });
  if (total > INT32_MAX) throw InputError(name, "too many vertices");
  Mesh& m = out.mesh;
  m.V.resize(static_cast<Eigen::Index>(total), 3);
  PolygonFaces faces;
  long long vertices = 0, points_lines = 0;
  for_each_line(b, [&](long long line, std::size_t q, std::size_t e) {
    const std::string_view kw = keyword(b, q, e);
    q += kw.size();
    if (kw == "v") {
      double xyz[3];
      read_vertex(b, q, e, name + ": line " + std::to_string(line), xyz);
      for (int d = 0; d < 3; ++d) m.V(vertices, d) = xyz[d];
      ++vertices;
    } else if (kw == "l" || kw == "p") {
      ++points_lines;
    } else if (kw == "f") {
      for (;;) {
        while (q < e && blank(b[q])) ++q;
        if (q >= e || b[q] == '#') break;
        std::size_t t = q;
        while (t < e && !blank(b[t]) && b[t] != '/') ++t;  // v, v/vt, v//vn, v/vt/vn
        const std::string_view tok = b.substr(q, t - q);
        long long v = 0;
        auto [r, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
        const bool whole = ec == std::errc() && r == tok.data() + tok.size();
        if (!whole || v == 0 || v > total || v < -vertices)
          throw InputError(name + ": line " + std::to_string(line),
                           "face vertex index " + shown(tok) +
                               (whole || ec == std::errc::result_out_of_range
                                    ? " out of range (the file has " + std::to_string(total) +
                                          " vertices; OBJ counts from 1, negatives back from the last one read)"
                                    : " is not an integer"));
        faces.corner(v > 0 ? v - 1 : vertices + v);
        while (t < e && !blank(b[t])) ++t;
        q = t;
      }
      faces.end_face();
    }
    // vt, vn, g, o, s, usemtl, mtllib and unknown keywords carry nothing for the surface.
  });
  faces.to_triangles(m, name, out.report);
  if (points_lines) out.report.warnings.push_back(name + ": " + std::to_string(points_lines) + " point/line elements ignored");
}

}  // namespace hocurve::io_detail
