// STL, binary and ASCII. STL stores every facet's own three points: weld them exactly.
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"
#include "engine/io/text_scanner.hpp"
#include "engine/io/weld_vertices.hpp"

#include <cmath>
#include <cstring>

namespace hocurve::io_detail {
namespace {

const char* bad_kind(double x) { return std::isnan(x) ? "a NaN" : "an infinite"; }

/// Fills mesh.V / mesh.F from n_facets*3 interleaved points, welding when asked.
template <class Real>
void build_from_soup(const std::vector<Real>& pts, const ReadOptions& opt, ReadResult& out) {
  const std::size_t np = pts.size() / 3, nf = np / 3;
  Mesh& m = out.mesh;
  m.F.resize(static_cast<Eigen::Index>(nf), 3);
  if (opt.weld) {
    WeldResult<Real> w = weld_exact(pts.data(), np);
    const std::size_t nu = w.points.size() / 3;
    m.V.resize(static_cast<Eigen::Index>(nu), 3);
    for (std::size_t v = 0; v < nu; ++v)
      for (int d = 0; d < 3; ++d) m.V(v, d) = static_cast<double>(w.points[3 * v + d]);
    for (std::size_t f = 0; f < nf; ++f)
      for (int j = 0; j < 3; ++j) m.F(f, j) = w.index[3 * f + j];
    out.report.welded_vertices = static_cast<long long>(np - nu);
  } else {
    m.V.resize(static_cast<Eigen::Index>(np), 3);
    for (std::size_t v = 0; v < np; ++v)
      for (int d = 0; d < 3; ++d) m.V(v, d) = static_cast<double>(pts[3 * v + d]);
    for (std::size_t f = 0; f < nf; ++f)
      for (int j = 0; j < 3; ++j) m.F(f, j) = static_cast<int>(3 * f + j);
  }
}

}  // namespace

void read_stl_binary(std::string_view b, const std::string& name, const ReadOptions& opt, ReadResult& out) {
  if (b.size() < 84)
    throw InputError(name, "truncated binary STL: " + std::to_string(b.size()) +
                               " bytes, a binary STL needs at least an 84-byte header");
  std::uint32_t n = 0;
  std::memcpy(&n, b.data() + 80, 4);
  const unsigned long long need = 84ull + 50ull * n;
  if (need > b.size()) {
    const unsigned long long whole = (b.size() - 84) / 50;
    throw InputError(name, "truncated binary STL: header declares " + std::to_string(n) + " facets (" +
                               std::to_string(need) + " bytes) but the file has " + std::to_string(b.size()) +
                               " bytes (facet " + std::to_string(whole) + " is incomplete or missing)");
  }
  if (n == 0) throw InputError(name, "binary STL declares 0 facets");
  // Whole facets beyond the declared count: the count is wrong, and reading it would silently drop
  // part of the surface. Other trailing bytes (text appended by some exporters) are ignored.
  if (const unsigned long long extra = b.size() - need; extra >= 50 && extra % 50 == 0)
    throw InputError(name, "binary STL header declares " + std::to_string(n) + " facets but the file's " +
                               std::to_string(b.size()) + " bytes hold exactly " +
                               std::to_string((b.size() - 84) / 50) +
                               ": the facet count is wrong (refused rather than dropping facets)");
  if (need < b.size())
    out.report.warnings.push_back(name + ": " + std::to_string(b.size() - need) +
                                  " bytes after the " + std::to_string(n) +
                                  " facets declared in the binary STL header were ignored");
  if (n > static_cast<std::uint32_t>(INT32_MAX / 3)) throw InputError(name, "too many facets for 32-bit indices");
  std::vector<float> pts(9ull * n);
  const char* p = b.data() + 84;
  for (std::uint32_t f = 0; f < n; ++f, p += 50) std::memcpy(&pts[9ull * f], p + 12, 36);
  for (std::uint32_t f = 0; f < n; ++f)
    for (int k = 0; k < 9; ++k)
      if (!std::isfinite(pts[9ull * f + k])) [[unlikely]]
        throw InputError(name + ": facet " + std::to_string(f),
                         "vertex " + std::to_string(k / 3) + " has " + bad_kind(pts[9ull * f + k]) +
                             " coordinate");
  build_from_soup(pts, opt, out);
}

void read_stl_ascii(std::string_view b, const std::string& name, const ReadOptions& opt, ReadResult& out) {
  TextScanner sc(b, name);
  std::vector<double> pts;
  std::vector<int> solid_of_facet;
  int solids = 0;
  long long facet = 0;
  auto expect = [&](std::string_view want) {
    sc.skip_space();
    const long long line = sc.line();
    const std::string_view t = sc.token();
    if (t != want)
      throw InputError(name + ": line " + std::to_string(line),
                       "expected '" + std::string(want) + "', found '" +
                           (t.empty() ? std::string("end of file") : std::string(t.substr(0, 40))) + "'");
  };
  while (!sc.at_end()) {
    expect("solid");
    ++solids;
    sc.next_line();  // the solid's name, if any
    for (;;) {
      sc.skip_space();
      const long long line = sc.line();
      const std::string_view t = sc.token();
      if (t == "endsolid") { sc.next_line(); break; }
      if (t != "facet")
        throw InputError(name + ": line " + std::to_string(line),
                         "expected 'facet' or 'endsolid', found '" +
                             (t.empty() ? std::string("end of file") : std::string(t.substr(0, 40))) + "'");
      sc.next_line();  // normal: recomputed from the vertices, never trusted
      expect("outer");
      expect("loop");
      std::size_t first = pts.size();
      int corners = 0;
      for (;;) {
        sc.skip_space();
        const long long vline = sc.line();
        const std::string_view k = sc.token();
        if (k == "endloop") break;
        if (k != "vertex")
          throw InputError(name + ": line " + std::to_string(vline),
                           "facet " + std::to_string(facet) + ": expected 'vertex' or 'endloop', found '" +
                               (k.empty() ? std::string("end of file") : std::string(k.substr(0, 40))) + "'");
        for (int d = 0; d < 3; ++d) {
          const double x = sc.number("a coordinate");
          if (!std::isfinite(x))
            throw InputError(name + ": line " + std::to_string(vline),
                             "facet " + std::to_string(facet) + ": vertex " + std::to_string(corners) + " has " +
                                 bad_kind(x) + " coordinate");
          pts.push_back(x);
        }
        ++corners;
      }
      if (corners < 3)
        throw InputError(name + ": line " + std::to_string(line),
                         "facet " + std::to_string(facet) + " has " + std::to_string(corners) + " vertices");
      if (corners > 3) {  // polygon facet (rare): fan-split around its first corner
        std::vector<double> poly(pts.begin() + first, pts.end());
        pts.resize(first);
        for (int c = 1; c + 1 < corners; ++c)
          for (int q : {0, c, c + 1}) pts.insert(pts.end(), poly.begin() + 3 * q, poly.begin() + 3 * q + 3);
      }
      solid_of_facet.resize(pts.size() / 9, solids);
      expect("endfacet");
      ++facet;
    }
  }
  build_from_soup(pts, opt, out);
  if (solids > 1) {  // like Gmsh: one surface entity per solid
    out.mesh.face_entity = Eigen::Map<Eigen::VectorXi>(solid_of_facet.data(), static_cast<Eigen::Index>(solid_of_facet.size()));
  }
}

}  // namespace hocurve::io_detail
