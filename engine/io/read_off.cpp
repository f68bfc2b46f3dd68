// OFF (and its C/N/ST variants): ASCII only. Extra per-vertex and per-face values are skipped.
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"
#include "engine/io/text_scanner.hpp"

namespace hocurve::io_detail {

void read_off(std::string_view b, const std::string& name, ReadResult& out) {
  TextScanner sc(b, name);
  const std::string_view head = sc.token('#');
  if (head.find("OFF") == std::string_view::npos) sc.fail("expected an OFF header");
  if (head.size() > 0 && (head[0] == '4' || head.find("n") != std::string_view::npos))
    sc.fail("OFF variant '" + std::string(head) + "' is not supported");
  const std::string_view maybe_binary = sc.token_on_line();
  if (maybe_binary == "BINARY") sc.fail("binary OFF is not supported");
  if (!maybe_binary.empty()) sc.seek(sc.pos() - maybe_binary.size());  // counts on the header line
  const long long nv = sc.integer("the vertex count", '#');
  const long long nf = sc.integer("the face count", '#');
  sc.integer("the edge count", '#');
  if (nv < 0 || nf < 0) sc.fail("negative vertex or face count");
  // Lying counts: each vertex needs at least 6 bytes ("0 0 0\n"), each face 8.
  if (static_cast<unsigned long long>(nv) > sc.remaining() / 6 + 1 ||
      static_cast<unsigned long long>(nf) > sc.remaining() / 8 + 1)
    sc.fail("header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
            " faces but only " + std::to_string(sc.remaining()) + " bytes follow");
  Mesh& m = out.mesh;
  m.V.resize(nv, 3);
  for (long long v = 0; v < nv; ++v) {
    sc.skip_space('#');
    if (sc.remaining() == 0)
      sc.fail("unexpected end of file at vertex " + std::to_string(v) + " of " + std::to_string(nv));
    for (int d = 0; d < 3; ++d) {
      const std::string_view t = sc.token_on_line();
      if (t.empty()) sc.fail("vertex " + std::to_string(v) + " has fewer than 3 coordinates");
      m.V(v, d) = sc.parse_double(t, "a coordinate");
    }
    sc.next_line();  // colours, normals, texture coordinates
  }
  PolygonFaces faces;
  for (long long f = 0; f < nf; ++f) {
    sc.skip_space('#');
    if (sc.remaining() == 0)
      sc.fail("unexpected end of file at face " + std::to_string(f) + " of " + std::to_string(nf));
    const long long n = sc.parse_int(sc.token_on_line(), "a face's corner count");
    if (n < 0 || n > 1000000) sc.fail("face " + std::to_string(f) + ": bad corner count " + std::to_string(n));
    for (long long c = 0; c < n; ++c) {
      const std::string_view t = sc.token_on_line();
      if (t.empty()) sc.fail("face " + std::to_string(f) + " lists fewer than " + std::to_string(n) + " vertices");
      const long long i = sc.parse_int(t, "a vertex index");
      if (i < 0 || i >= nv)
        sc.fail("face " + std::to_string(f) + ": vertex index " + std::to_string(i) + " out of range (the file has " +
                std::to_string(nv) + " vertices)");
      faces.corner(i);
    }
    sc.next_line();  // optional colour
    faces.end_face();
  }
  faces.to_triangles(m, name, out.report);
}

}  // namespace hocurve::io_detail
