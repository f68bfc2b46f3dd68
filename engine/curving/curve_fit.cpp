#include "engine/curving/curve_fit.hpp"

#include "engine/core/stopwatch.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

namespace hocurve {

namespace {

/// The feature edges at v (ascending edge index).
std::vector<int> feature_edges_at(const Topology& T, const Features& feat, int v) {
  std::vector<int> out;
  auto [b, e] = T.edges_of(v);
  for (const int* p = b; p != e; ++p)
    if (feat.edge_feature[*p]) out.push_back(*p);
  std::sort(out.begin(), out.end());
  return out;
}

double edge_length(const Mesh& mesh, const Topology& T, int e) {
  return (mesh.V.row(T.E(e, 0)) - mesh.V.row(T.E(e, 1))).norm();
}

/// v continues the curve: a non-corner vertex with exactly two feature edges whose lengths differ
/// by at most opt.curve_break_ratio (a bigger jump marks where a CAD exporter's sampling changes,
/// e.g. a straight segment, one long edge, meeting an arc of short ones: a fit across the junction
/// would carry the arc's curvature along the straight edge).
bool through(const Mesh& mesh, const Topology& T, const Features& feat, int v, const FitOptions& opt) {
  if (feat.vertex_corner[v]) return false;
  const std::vector<int> fe = feature_edges_at(T, feat, v);
  if (fe.size() != 2) return false;
  const double a = edge_length(mesh, T, fe[0]), b = edge_length(mesh, T, fe[1]);
  return std::max(a, b) <= opt.curve_break_ratio * std::min(a, b);
}

/// Walks from v across e and onwards through vertices that continue the curve, up to count vertices.
void walk(const Mesh& mesh, const Topology& T, const Features& feat, const FitOptions& opt, int v, int e,
          int count, std::vector<int>& out) {
  int prev = v, edge = e;
  for (int i = 0; i < count; ++i) {
    const int u = T.other(edge, prev);
    if (u == v) break;  // closed loop
    out.push_back(u);
    if (!through(mesh, T, feat, u, opt)) break;
    auto fe = feature_edges_at(T, feat, u);
    edge = fe[0] == edge ? fe[1] : fe[0];
    prev = u;
  }
}

}  // namespace

Eigen::Vector3d CurveFit::coords(const Eigen::Vector3d& q) const {
  const Eigen::Vector3d d = q - o;
  const double x = d.dot(t), y = d.dot(n1), z = d.dot(n2);
  if (kappa == 0) return {x, y, z};
  // Polar coordinates about the centre (0, R) of the (t, n1) plane; R - |q - centre| written
  // without cancellation.
  const double R = 1.0 / kappa, r = std::sqrt(x * x + (R - y) * (R - y));
  return {R * std::atan2(x, R - y), (2 * R * y - x * x - y * y) / (R + r), z};
}

Eigen::Vector3d CurveFit::project(const Eigen::Vector3d& x) const {
  const double s = coords(x)[0];
  double y = 0, z = 0, pw = 1;
  for (int j = 0; j < degree; ++j) {
    pw *= s / h;
    y += cy[j] * pw;
    z += cz[j] * pw;
  }
  if (kappa == 0) return o + s * t + h * (y * n1 + z * n2);
  const double R = 1.0 / kappa, phi = s * kappa, rho = R - h * y, half = std::sin(0.5 * phi);
  return o + rho * std::sin(phi) * t + (2 * R * half * half + h * y * std::cos(phi)) * n1 + h * z * n2;
}

CurveFit fit_curve_at(const Mesh& mesh, const Topology& T, const Features& feat, int v, int e,
                      int p, const FitOptions& opt) {
  CurveFit C;
  C.o = mesh.V.row(v).transpose();
  const int per_side = p + 1;
  std::vector<int> fwd, bwd;
  walk(mesh, T, feat, opt, v, e, per_side, fwd);
  if (through(mesh, T, feat, v, opt)) {
    auto fe = feature_edges_at(T, feat, v);
    walk(mesh, T, feat, opt, v, fe[0] == e ? fe[1] : fe[0], per_side, bwd);
  }
  // Tangent from the two neighbours (or the one, at corners and curve ends).
  Eigen::Vector3d t = (mesh.V.row(fwd[0]).transpose() - C.o).normalized();
  if (!bwd.empty()) t = (t - (mesh.V.row(bwd[0]).transpose() - C.o).normalized()).normalized();
  std::vector<int> pts(fwd);
  pts.insert(pts.end(), bwd.begin(), bwd.end());
  const int k = static_cast<int>(pts.size());
  C.points = k;
  C.h = (mesh.V.row(fwd[0]).transpose() - C.o).norm();
  if (!bwd.empty()) C.h = 0.5 * (C.h + (mesh.V.row(bwd[0]).transpose() - C.o).norm());
  if (!(C.h > 0)) C.h = 1.0;
  std::vector<double> dist(k);
  for (int i = 0; i < k; ++i) dist[i] = (mesh.V.row(pts[i]).transpose() - C.o).norm();
  std::vector<double> sd(dist);
  std::sort(sd.begin(), sd.end());
  const int need = std::max(1, std::min(k, static_cast<int>(std::ceil(opt.curve_points_per_coef * p))));
  const double sigma = std::max(opt.sigma_factor * C.h, 0.5 * sd[need - 1]);

  // Fits in the frame (tan, n1 = normal, tan x n1) over the reference circle of curvature kappa.
  auto solve = [&](const Eigen::Vector3d& tan, const Eigen::Vector3d& normal, double kappa, CurveFit& out) {
    out.t = tan;
    out.n1 = (normal - normal.dot(tan) * tan).normalized();
    out.n2 = tan.cross(out.n1);
    out.kappa = kappa;
    for (int deg = std::min(p, k); deg >= 1; --deg) {
      Eigen::MatrixXd A(k, deg);
      Eigen::MatrixXd B(k, 2);
      for (int i = 0; i < k; ++i) {
        const Eigen::Vector3d q = out.coords(mesh.V.row(pts[i]).transpose()) / out.h;
        const double w = std::exp(-dist[i] * dist[i] / (2 * sigma * sigma));
        double pw = 1;
        for (int j = 0; j < deg; ++j) A(i, j) = w * (pw *= q[0]);
        B(i, 0) = w * q[1];
        B(i, 1) = w * q[2];
      }
      Eigen::VectorXd scale(deg);
      for (int j = 0; j < deg; ++j) scale[j] = 1.0 / std::max(A.col(j).norm(), 1e-300), A.col(j) *= scale[j];
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
      qr.setThreshold(opt.rank_tol);
      if (qr.rank() < deg) continue;
      Eigen::MatrixXd X = qr.solve(B);
      if (!X.allFinite()) continue;
      out.degree = deg;
      out.cy = X.col(0).cwiseProduct(scale);
      out.cz = X.col(1).cwiseProduct(scale);
      return;
    }
    out.degree = 0;
  };
  Eigen::Vector3d n1, n2;
  tangent_frame(t, n1, n2);  // any normal: the fit is the same in every normal frame
  solve(t, n1, 0.0, C);
  // Refine the tangent from the first fit's slope at s = 0.
  if (C.degree >= 1) {
    Eigen::Vector3d t1 = (C.t + C.cy[0] * C.n1 + C.cz[0] * C.n2).normalized();
    if (t1.dot(t) > 0.5) solve(t1, C.n1, 0.0, C);
  }
  // Refit over a reference circle: the circle through o that fits the points best (least
  // squares on |d|^2 = 2 c.d in the plane of the tangent and the points' main offset from it)
  // where the points lie on it (within circle_tolerance x h: circular arcs of CAD rims, holes
  // and fillets, exact however few points they have) or where it is determined by at most two
  // points; else the osculating circle of that fit (curvature vector 2 (cy_2 n1 + cz_2 n2) / h,
  // limited to 1.5 / the stencil's reach so that every point stays within about 150 degrees of
  // o on it). Measured: through 3 points of a quarter circle a polynomial's curvature is off by
  // 3x; on the noisy rims of scans the least-squares circle moved the maximum deviation from
  // the input both ways (stanford_bunny_scan 0.29% -> 0.26%, skull 0.48% -> 0.52%).
  if (opt.curve_reference_circle && C.degree >= 2) {
    const double reach = sd.back();
    const CurveFit line = C;
    auto refit = [&](const Eigen::Vector3d& tan, const Eigen::Vector3d& normal, double kappa) {
      if (!(kappa * reach > 1e-3) || !(tan.dot(line.t) > 0.5)) return false;
      CurveFit R = line;
      solve(tan, normal, kappa, R);
      if (R.degree >= 1) C = R;
      return R.degree >= 1;
    };
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (int i = 0; i < k; ++i) {
      Eigen::Vector3d d = mesh.V.row(pts[i]).transpose() - line.o;
      d -= d.dot(line.t) * line.t;
      M += d * d.transpose();
    }
    // Points on the tangent line (to circle_tolerance) determine no circle: with two of them the
    // least-squares circle was whatever its singular system gave (a straight CAD edge with
    // one inside vertex between two corners came out an arc of radius h / 2, 7e-4 off at h = 0.1).
    double offset = 0;
    for (int i = 0; i < k; ++i) {
      Eigen::Vector3d d = mesh.V.row(pts[i]).transpose() - line.o;
      offset = std::max(offset, (d - d.dot(line.t) * line.t).norm());
    }
    const Eigen::Vector3d m1 = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(M).eigenvectors().col(2);
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (int i = 0; i < k; ++i) {
      const Eigen::Vector3d d = mesh.V.row(pts[i]).transpose() - line.o;
      const double w = std::exp(-dist[i] * dist[i] / (2 * sigma * sigma));
      const Eigen::Vector2d x(d.dot(line.t), d.dot(m1));
      A += w * x * x.transpose();
      b += w * x * (0.5 * d.squaredNorm());
    }
    const Eigen::Vector2d ab = A.ldlt().solve(b);
    const Eigen::Vector3d c = ab[0] * line.t + ab[1] * m1;
    bool on_circle = offset > opt.circle_tolerance * line.h && ab.allFinite() && c.norm() > 0;
    // Every point on it, within 170 degrees of o about the centre (beyond 180 the arc length wraps).
    for (int i = 0; i < k && on_circle; ++i) {
      const Eigen::Vector3d d = mesh.V.row(pts[i]).transpose() - line.o - c;
      on_circle = (k <= 2 || std::abs(d.norm() - c.norm()) <= opt.circle_tolerance * line.h) &&
                  std::atan2(d.cross(-c).norm(), -d.dot(c)) <= 170.0 / 180.0 * std::numbers::pi;
    }
    const Eigen::Vector3d cn = c.normalized();
    if (on_circle && refit((line.t - line.t.dot(cn) * cn).normalized(), cn, 1.0 / c.norm())) {
      C.on_circle = k >= 3;
    } else {
      const Eigen::Vector3d kv = 2 * (line.cy[1] * line.n1 + line.cz[1] * line.n2) / line.h;
      refit(line.t, kv, std::min(kv.norm(), 1.5 / reach));
    }
  }
  // Sanity bound: along edge e the curve may not leave the chord by more than max_offset x
  // the edge length; else one degree lower (degree 0 is the chord itself).
  const Eigen::Vector3d far = mesh.V.row(T.other(e, v)).transpose();
  const double len = (far - C.o).norm();
  bool sane = C.cy.allFinite() && C.cz.allFinite();
  for (int i = 1; i < 8 && sane && C.degree > 0; ++i) {
    const Eigen::Vector3d x = C.o + (i / 8.0) * (far - C.o);
    sane = (C.project(x) - x).norm() <= opt.max_offset * len;
  }
  if (!sane && C.degree > 0) {
    if (p > 1) return fit_curve_at(mesh, T, feat, v, e, std::min(p - 1, C.degree), opt);
    C.degree = 0;
    C.kappa = 0;
  }
  return C;
}

namespace {

/// Whether c lies on the line through a and b to the input's rounding (ExactQuadricOptions).
bool collinear(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
               const ExactQuadricOptions& exact) {
  const Eigen::Vector3d u = b - a;
  if (!(u.norm() > 0)) return false;
  const double scale = std::max({a.norm(), b.norm(), c.norm()});
  const double rounding = std::max(exact.rounding > 0 ? exact.rounding : std::ldexp(1.0, -24), 1e-8);
  return (c - a).cross(u).norm() / u.norm() <= exact.tolerance * rounding * scale;
}

/// The line from a to b as a curve fit (no offsets).
CurveFit line_fit(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  CurveFit C;
  C.o = a;
  C.h = (b - a).norm();
  C.t = (b - a) / C.h;
  tangent_frame(C.t, C.n1, C.n2);
  return C;
}

/// Straight curve edges: an edge of a feature curve whose ends and a neighbour along the curve lie
/// on one line (to rounding) is a line segment, as three points of a smooth CAD curve are collinear
/// only on a straight piece. Its end fits become that line: a fit through the chain bends where a
/// line meets an arc and carries the arc into the line's last edge (a rib's top edge beside a hole,
/// 1e-2 out of both its planes). Returns the number of edges made straight.
long long straighten_line_edges(const Mesh& mesh, const Topology& T, const Features& feat,
                                const FitOptions& opt, CurveFitResult& R) {
  auto edge_between = [&](int a, int b) {
    auto [first, last] = T.edges_of(a);
    for (const int* e = first; e != last; ++e)
      if (T.other(*e, a) == b) return *e;
    return -1;
  };
  long long n = 0;
  for (const std::vector<int>& c : feat.curves) {
    const int m = static_cast<int>(c.size());
    const bool closed = m > 2 && c.front() == c.back();
    auto at = [&](int i) -> int {  // chain vertex i, wrapping round a closed curve, -1 past an end
      if (closed) return c[((i % (m - 1)) + (m - 1)) % (m - 1)];
      return i >= 0 && i < m ? c[i] : -1;
    };
    for (int i = 0; i + 1 < m; ++i) {
      const int e = edge_between(c[i], c[i + 1]);
      if (e < 0 || !R.fitted_edge(e)) continue;
      const Eigen::Vector3d a = mesh.V.row(c[i]).transpose(), b = mesh.V.row(c[i + 1]).transpose();
      bool line = false;
      for (int k : {at(i - 1), at(i + 2)})
        line = line || (k >= 0 && k != c[i] && k != c[i + 1] && collinear(a, b, mesh.V.row(k).transpose(), opt.exact));
      if (!line) continue;
      const bool forward = T.E(e, 0) == c[i];
      R.fits[R.first[e]] = line_fit(forward ? a : b, forward ? b : a);
      R.fits[R.first[e] + 1] = R.fits[R.first[e]];
      ++n;
    }
  }
  return n;
}

}  // namespace

CurveFitResult fit_feature_curves(const Mesh& mesh, const Topology& T, const Features& feat,
                                  int p, const FitOptions& opt) {
  const auto t0 = Clock::now();
  CurveFitResult R;
  const int ne = T.num_edges();
  R.first.assign(ne, -1);
  std::vector<int> edges;
  for (int e = 0; e < ne && !feat.edge_feature.empty(); ++e)
    if (feat.edge_feature[e]) R.first[e] = 2 * static_cast<int>(edges.size()), edges.push_back(e);
  R.fits.resize(2 * edges.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, edges.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i)
      for (int s = 0; s < 2; ++s) R.fits[2 * i + s] = fit_curve_at(mesh, T, feat, T.E(edges[i], s), edges[i], p, opt);
  });
  for (const CurveFit& c : R.fits) {
    ++R.fitted;
    if (c.degree < p) ++R.downgraded;
  }
  R.straight = straighten_line_edges(mesh, T, feat, opt, R);
  R.seconds = seconds_since(t0);
  return R;
}

Eigen::Vector3d curve_edge_point(const Mesh& mesh, const Topology& T, const CurveFitResult& C,
                                 int e, double t) {
  const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)).transpose(), b = mesh.V.row(T.E(e, 1)).transpose();
  const Eigen::Vector3d x = (1 - t) * a + t * b;
  return (1 - t) * C.at(e, 0).project(x) + t * C.at(e, 1).project(x);
}

}  // namespace hocurve
