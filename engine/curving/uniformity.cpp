#include "engine/curving/uniformity.hpp"

#include "engine/core/error.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace hocurve {

Spread spread_of(std::vector<double> x) {
  Spread s;
  if (x.empty()) return s;
  const size_t n = x.size();
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  s.min = *lo, s.max = *hi;
  double sum = 0;
  for (double v : x) sum += v;
  s.mean = sum / n;
  double var = 0;
  for (double v : x) var += (v - s.mean) * (v - s.mean);
  var /= n;
  s.cv = s.mean != 0 ? std::sqrt(var) / s.mean : 0;
  // Linear interpolation between order statistics (numpy's default percentile). Selected, not
  // sorted: the 2.39M sphere's check took 0.64 s with four full sorts, 0.09 s so.
  auto pct = [&](double q) {
    const double pos = q / 100.0 * (n - 1);
    const size_t i = static_cast<size_t>(std::floor(pos));
    const double t = pos - i;
    std::nth_element(x.begin(), x.begin() + i, x.end());
    if (i + 1 >= n) return x[i];
    const double next = *std::min_element(x.begin() + i + 1, x.end());  // all >= x[i] now
    return x[i] + t * (next - x[i]);
  };
  s.p1 = pct(1), s.p99 = pct(99);
  return s;
}

Uniformity check_uniformity(const Mesh& mesh, const Topology& T, const UniformityOptions& opt) {
  if (!(opt.max_edge_ratio > 0) || !(opt.max_needle_share >= 0) || !(opt.needle_aspect > 0))
    throw InputError("uniformity", "thresholds must be positive");
  if (T.FE.rows() != mesh.num_faces() || (T.num_edges() > 0 && T.E.maxCoeff() >= mesh.num_vertices()))
    throw InputError("uniformity", "topology was built for another mesh");
  Uniformity U;
  std::vector<double> len(T.num_edges());
  for (int e = 0; e < T.num_edges(); ++e) len[e] = (mesh.V.row(T.E(e, 0)) - mesh.V.row(T.E(e, 1))).norm();
  const int nf = mesh.num_faces();
  std::vector<double> area(nf), aspect, aspect_n;
  aspect.reserve(nf);
  aspect_n.reserve(nf);
  long long needles = 0, needles_n = 0, degenerate = 0;
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    area[f] = 0.5 * (b - a).cross(c - a).norm();
    const double l0 = (b - a).norm(), l1 = (c - b).norm(), l2 = (a - c).norm();
    const double lmax = std::max({l0, l1, l2});
    // Longest edge over shortest altitude; the shortest altitude is 2A / longest edge.
    if (area[f] > 0) {
      const double asp = lmax * lmax / (2 * area[f]);
      aspect.push_back(asp);
      if (asp > opt.needle_aspect) ++needles;
      // inradius = 2A / perimeter
      const double asp_n = lmax * (l0 + l1 + l2) / (4 * std::sqrt(3.0) * area[f]);
      aspect_n.push_back(asp_n);
      if (asp_n > opt.needle_aspect) ++needles_n;
    } else {
      ++needles, ++needles_n, ++degenerate;  // zero area: infinitely thin, kept out of the aspect spreads
    }
  }
  U.edge_length = spread_of(std::move(len));
  U.area = spread_of(std::move(area));
  U.aspect = spread_of(std::move(aspect));
  U.aspect_normalized = spread_of(std::move(aspect_n));
  U.needle_share = nf ? static_cast<double>(needles) / nf : 0.0;
  U.needle_share_normalized = nf ? static_cast<double>(needles_n) / nf : 0.0;
  U.degenerate_faces = degenerate;

  char buf[200];
  const double er = U.edge_length.ratio_p99_p1();
  if (U.edge_length.p1 <= 0 && T.num_edges() > 0) {
    U.uniform = false;
    U.reason = "zero-length edges among the shortest 1%";
  } else if (er > opt.max_edge_ratio) {
    U.uniform = false;
    std::snprintf(buf, sizeof buf, "edge length p99/p1 = %.3g > %.3g", er, opt.max_edge_ratio);
    U.reason = buf;
  }
  if (U.needle_share > opt.max_needle_share) {
    U.uniform = false;
    std::snprintf(buf, sizeof buf, "needle share (aspect > %.3g) = %.3g > %.3g", opt.needle_aspect, U.needle_share,
                  opt.max_needle_share);
    U.reason += (U.reason.empty() ? "" : "; ") + std::string(buf);
  }
  return U;
}

}  // namespace hocurve
