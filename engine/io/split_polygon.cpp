// Triangles of the polygons of indexed formats (OBJ, PLY, OFF).
#include "engine/io/format_readers.hpp"

namespace hocurve::io_detail {

void split_polygon(const Eigen::MatrixXd& V, const std::vector<long long>& poly, std::vector<int>& tri) {
  const std::size_t n = poly.size();
  if (n < 3) return;
  const auto corner = [&](std::size_t c) { return static_cast<int>(poly[c]); };
  if (n == 4) {
    // The shorter diagonal gives the better-shaped pair (and the flatter one on a curved surface).
    const bool cut02 = (V.row(corner(0)) - V.row(corner(2))).squaredNorm() <=
                       (V.row(corner(1)) - V.row(corner(3))).squaredNorm();
    if (cut02) tri.insert(tri.end(), {corner(0), corner(1), corner(2), corner(0), corner(2), corner(3)});
    else tri.insert(tri.end(), {corner(0), corner(1), corner(3), corner(1), corner(2), corner(3)});
    return;
  }
  for (std::size_t c = 1; c + 1 < n; ++c) tri.insert(tri.end(), {corner(0), corner(c), corner(c + 1)});
}

std::string polygons_warning(const std::string& name, long long polygons) {
  return name + ": " + std::to_string(polygons) +
         " polygons with more than 3 corners were split into triangles (quadrangles along their shorter diagonal)";
}

}  // namespace hocurve::io_detail
