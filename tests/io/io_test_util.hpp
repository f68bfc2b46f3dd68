// Helpers for the io tests: small meshes and independent writers for every input format.
#pragma once
#include "engine/core/mesh.hpp"

#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace iotest {

/// Octahedron with float-exact, distinct, non-symmetric coordinates; outward CCW faces.
inline hocurve::Mesh octahedron() {
  hocurve::Mesh m;
  m.V.resize(6, 3);
  m.V << 1.5, 0.25, 0, -1.25, 0.25, 0, 0.125, 1.75, 0, 0.125, -1.5, 0, 0.125, 0.25, 2.5, 0.125, 0.25, -1;
  // vertex 0:+x 1:-x 2:+y 3:-y 4:+z 5:-z
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

inline std::string num(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

inline std::string stl_ascii(const hocurve::Mesh& m, const std::string& solid = "test") {
  std::ostringstream s;
  s << "solid " << solid << "\n";
  for (int f = 0; f < m.num_faces(); ++f) {
    s << "  facet normal 0 0 0\n    outer loop\n";
    for (int j = 0; j < 3; ++j)
      s << "      vertex " << num(m.V(m.F(f, j), 0)) << " " << num(m.V(m.F(f, j), 1)) << " " << num(m.V(m.F(f, j), 2)) << "\n";
    s << "    endloop\n  endfacet\n";
  }
  s << "endsolid " << solid << "\n";
  return s.str();
}

inline std::string stl_binary(const hocurve::Mesh& m, const std::string& header = "binary test") {
  std::string out(80, ' ');
  std::memcpy(out.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  const std::uint32_t n = static_cast<std::uint32_t>(m.num_faces());
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (int f = 0; f < m.num_faces(); ++f) {
    float rec[12] = {0};
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) rec[3 + 3 * j + d] = static_cast<float>(m.V(m.F(f, j), d));
    out.append(reinterpret_cast<const char*>(rec), 48);
    out.append(2, '\0');
  }
  return out;
}

inline std::string off_text(const hocurve::Mesh& m) {
  std::ostringstream s;
  s << "OFF\n# comment line\n" << m.num_vertices() << " " << m.num_faces() << " 0\n";
  for (int v = 0; v < m.num_vertices(); ++v) s << num(m.V(v, 0)) << " " << num(m.V(v, 1)) << " " << num(m.V(v, 2)) << "\n";
  for (int f = 0; f < m.num_faces(); ++f) s << "3 " << m.F(f, 0) << " " << m.F(f, 1) << " " << m.F(f, 2) << "\n";
  return s.str();
}

inline std::string obj_text(const hocurve::Mesh& m) {
  std::ostringstream s;
  s << "# test\no thing\n";
  for (int v = 0; v < m.num_vertices(); ++v) s << "v " << num(m.V(v, 0)) << " " << num(m.V(v, 1)) << " " << num(m.V(v, 2)) << "\n";
  s << "vn 0 0 1\n";
  for (int f = 0; f < m.num_faces(); ++f) s << "f " << m.F(f, 0) + 1 << "//1 " << m.F(f, 1) + 1 << "//1 " << m.F(f, 2) + 1 << "//1\n";
  return s.str();
}

/// gzip-compresses with zlib's gzip wrapper.
inline std::string gzip(const std::string& in) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) throw std::runtime_error("zlib");
  std::string out(compressBound(in.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  if (deflate(&zs, Z_FINISH) != Z_STREAM_END) throw std::runtime_error("zlib deflate");
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

inline void write_file(const std::string& path, const std::string& data) {
  std::ofstream o(path, std::ios::binary);
  o.write(data.data(), static_cast<std::streamsize>(data.size()));
}

inline std::string tmp_path(const std::string& leaf) {
  return std::string(HOCURVE_BINARY_DIR) + "/io_test_" + leaf;
}

}  // namespace iotest
