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

void PolygonFaces::end_face() {
  const std::size_t n = corners_.size() - begin_;
  if (n < 3) {
    ++small_;
    corners_.resize(begin_);
    return;
  }
  polygons_ += n > 3;
  ends_.push_back(corners_.size());
  begin_ = corners_.size();
}

void PolygonFaces::to_triangles(Mesh& m, const std::string& name, ReadReport& report) const {
  std::vector<int> tri;
  tri.reserve(3 * (corners_.size() - 2 * ends_.size()));
  std::vector<long long> poly;
  std::size_t b = 0;
  for (const std::size_t e : ends_) {
    poly.assign(corners_.begin() + static_cast<std::ptrdiff_t>(b), corners_.begin() + static_cast<std::ptrdiff_t>(e));
    split_polygon(m.V, poly, tri);
    b = e;
  }
  m.F.resize(static_cast<Eigen::Index>(tri.size() / 3), 3);
  for (std::size_t f = 0; f < tri.size() / 3; ++f)
    for (int j = 0; j < 3; ++j) m.F(static_cast<Eigen::Index>(f), j) = tri[3 * f + j];
  if (polygons_)
    report.warnings.push_back(name + ": " + std::to_string(polygons_) +
                              " polygons with more than 3 corners were split into triangles (quadrangles along "
                              "their shorter diagonal)");
  if (small_) report.warnings.push_back(name + ": " + std::to_string(small_) + " faces with fewer than 3 corners ignored");
}

}  // namespace hocurve::io_detail
