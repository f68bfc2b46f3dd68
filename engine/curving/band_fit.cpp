#include "engine/curving/band_fit.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace hocurve {

namespace {

/// The feature edges at the vertex of wedge w that bound the wedge's faces (ascending).
std::vector<int> bounding_feature_edges(const Mesh& mesh, const Topology& T, const Wedges& W,
                                        const Features& feat, int w) {
  const int v = W.wedge_vertex[w];
  std::vector<int> out;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    for (int j = 0; j < 3; ++j) {
      const int e = T.FE(f, j);
      if ((mesh.F(f, j) == v || mesh.F(f, (j + 1) % 3) == v) && feat.edge_feature[e]) out.push_back(e);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// Index of monomial u^j v^k in LocalFit's coefficient order (by degree, then descending j).
int monomial_index(int j, int k) {
  const int d = j + k;
  return (d - 1) * (d + 2) / 2 + k;
}

/// LocalFit coefficients (monomials u^j v^k) of the ruled model sum_j x_j s^(j+1) + r sum_j
/// x_(deg+j) s^j, with s = u - tan_phi v along the curve and r = v / cos_phi along the rulings.
Eigen::VectorXd ruled_coefficients(const Eigen::VectorXd& x, int deg, double tan_phi, double cos_phi) {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(fit_coefficients(deg));
  // s^n v^extra_v = sum_i C(n, i) u^(n - i) (-tan_phi)^i v^(i + extra_v) (n + extra_v >= 1: no constant)
  auto add_power = [&](int n, int extra_v, double coef) {
    double binom = 1, t = 1;
    for (int i = 0; i <= n; ++i) {
      c[monomial_index(n - i, i + extra_v)] += coef * binom * t;
      binom = binom * (n - i) / (i + 1);
      t *= -tan_phi;
    }
  };
  for (int j = 0; j < deg; ++j) {
    add_power(j + 1, 0, x[j]);
    add_power(j, 1, x[deg + j] / cos_phi);
  }
  return c;
}

/// The fit moves no point of the wedge's faces by more than fit_offset_limit (fit_wedge's
/// sanity bound: beyond it the fit extrapolates).
bool moves_little(const Mesh& mesh, const Wedges& W, int w, const LocalFit& fit, const FitOptions& opt) {
  if (!fit.c.allFinite()) return false;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const double limit = fit_offset_limit(a, b, c, opt);
    for (int j = 0; j <= 4; ++j)
      for (int k = 0; j + k <= 4; ++k) {
        const Eigen::Vector3d x = a + (j / 4.0) * (b - a) + (k / 4.0) * (c - a);
        if (!((fit.project(x) - x).norm() <= limit)) return false;
      }
  }
  return true;
}

}  // namespace

bool is_band_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat, int w) {
  const int v = W.wedge_vertex[w];
  if (feat.edge_feature.empty() || !feat.vertex_feature[v]) return false;
  const std::vector<int> be = bounding_feature_edges(mesh, T, W, feat, w);
  if (be.size() != 2) return false;
  const Eigen::Vector3d o = mesh.V.row(v);
  const Eigen::Vector3d d0 = (Eigen::Vector3d(mesh.V.row(T.other(be[0], v))) - o).normalized();
  const Eigen::Vector3d d1 = (Eigen::Vector3d(mesh.V.row(T.other(be[1], v))) - o).normalized();
  if (d0.dot(d1) > -0.5) return false;  // the curve turns by 60 degrees or more here
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i)
    for (int j = 0; j < 3; ++j)
      if (!feat.vertex_feature[mesh.F(W.wedge_faces[i], j)]) return false;
  return true;
}

LocalFit fit_band_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat,
                        int w, int p, const LocalFit& base, const FitOptions& opt) {
  const int v = W.wedge_vertex[w];
  const Eigen::Vector3d o = mesh.V.row(v);
  const std::vector<int> be = bounding_feature_edges(mesh, T, W, feat, w);
  const Eigen::Vector3d d0 = (Eigen::Vector3d(mesh.V.row(T.other(be[0], v))) - o).normalized();
  const Eigen::Vector3d d1 = (Eigen::Vector3d(mesh.V.row(T.other(be[1], v))) - o).normalized();
  LocalFit F = base;
  F.requested_degree = p;
  const Eigen::Vector3d n = base.n;
  Eigen::Vector3d t = d0 - d1;
  t -= t.dot(n) * n;
  if (!(t.norm() > 0)) return base;
  F.t1 = t.normalized();
  F.t2 = n.cross(F.t1);
  F.identity = false;

  const int ncoef = 2 * p;  // u^1..u^p and v u^0..v u^(p-1)
  StencilOptions so;
  so.min_rings = 1;
  so.max_rings = opt.max_rings;
  so.target_points = static_cast<int>(std::ceil(opt.points_per_coef * ncoef)) + 1;
  so.max_points = opt.max_points;
  const Stencil S = grow_stencil(mesh, T, W, w, so);
  const int k = static_cast<int>(S.vertices.size()) - 1;
  if (k < 2) return base;
  std::vector<double> dist(k);
  for (int i = 0; i < k; ++i) dist[i] = (Eigen::Vector3d(mesh.V.row(S.vertices[i + 1])) - o).norm();
  std::vector<double> sd(dist);
  std::sort(sd.begin(), sd.end());
  const double h = base.h;
  const double sigma = std::max(opt.sigma_factor * h, opt.sigma_reach * sd[std::min(k, so.target_points - 1) - 1]);

  // Rulings at angle phi to t2 (toward t1): coordinates s along t1, r along the ruling. checked:
  // the residual is infinite unless the fit moves_little (the search checks only its winner).
  auto fit_at = [&](double phi, int deg, double& residual, bool checked = true) {
    LocalFit G = F;
    residual = std::numeric_limits<double>::infinity();
    const int m = 2 * deg;
    if (k < m) return G;
    const double tan_phi = std::tan(phi), cos_phi = std::cos(phi);
    Eigen::MatrixXd A(k, m);
    Eigen::VectorXd b(k);
    for (int i = 0; i < k; ++i) {
      const Eigen::Vector3d d = Eigen::Vector3d(mesh.V.row(S.vertices[i + 1])) - o;
      const double v = d.dot(F.t2) / h, r = v / cos_phi, su = d.dot(F.t1) / h - v * tan_phi;
      const double wt = std::exp(-dist[i] * dist[i] / (2 * sigma * sigma));
      double ps = 1;
      for (int j = 0; j < deg; ++j) {
        A(i, deg + j) = wt * r * ps;  // r s^j
        ps *= su;
        A(i, j) = wt * ps;            // s^(j+1)
      }
      b[i] = wt * d.dot(n) / h;
    }
    Eigen::VectorXd scale(m);
    for (int j = 0; j < m; ++j) {
      const double c = A.col(j).norm();
      if (!(c > 0)) return G;
      scale[j] = 1.0 / c;
      A.col(j) *= scale[j];
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    qr.setThreshold(opt.rank_tol);
    if (qr.rank() < m) return G;
    const Eigen::VectorXd y = qr.solve(b);
    Eigen::VectorXd x = y.array() * scale.array();
    if (!x.allFinite()) return G;
    G.degree = deg;
    G.c = ruled_coefficients(x, deg, tan_phi, cos_phi);
    G.points = k;
    G.support_points = 0;
    G.rings = S.rings;
    G.pivot_ratio = std::abs(qr.matrixQR()(m - 1, m - 1)) / std::max(std::abs(qr.matrixQR()(0, 0)), 1e-300);
    if (!checked || moves_little(mesh, W, w, G, opt)) residual = (A * y - b).norm();
    return G;
  };
  // Across the band (phi = 0) at the highest degree the stencil determines...
  int deg = p;
  double best = 0;
  LocalFit B;
  for (; deg >= 1; --deg) {
    B = fit_at(0, deg, best);
    if (std::isfinite(best)) break;
  }
  if (deg < 1) return base;
  // ... then along the rulings that fit the band best at that degree, where they fit it much
  // better (FitOptions::band_ruling_max_deg and what follows it).
  if (opt.band_ruling_max_deg > 0 && k >= 2 * deg + opt.band_ruling_spare_points) {
    const LocalFit across = B;
    const double across_residual = best;
    const double step = opt.band_ruling_step_deg * std::numbers::pi / 180, most = opt.band_ruling_max_deg * std::numbers::pi / 180;
    double at = 0;
    for (double phi = -most; phi <= most + 1e-12; phi += step) {
      double res = 0;
      LocalFit G = fit_at(phi, deg, res, false);
      if (res < best) best = res, B = std::move(G), at = phi;
    }
    double lo = std::max(at - step, -most), hi = std::min(at + step, most);
    const double g = (std::sqrt(5.0) - 1) / 2;
    for (int it = 0; it < opt.band_ruling_refinements; ++it) {
      const double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
      double r1 = 0, r2 = 0;
      LocalFit G1 = fit_at(x1, deg, r1, false), G2 = fit_at(x2, deg, r2, false);
      if (r1 < best) best = r1, B = std::move(G1);
      if (r2 < best) best = r2, B = std::move(G2);
      if (r1 <= r2) hi = x2;
      else lo = x1;
    }
    if (!(best <= opt.band_ruled_residual) || !(best <= opt.band_ruling_gain * across_residual) ||
        !moves_little(mesh, W, w, B, opt))
      return across;
  }
  return B;
}

long long refit_band_wedges(const Mesh& mesh, const Topology& T, const Wedges& W,
                            const Features& feat, int p, const FitOptions& opt,
                            std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  std::vector<char> band(nw, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, nw), [&](const tbb::blocked_range<int>& r) {
    for (int w = r.begin(); w < r.end(); ++w)
      if (!fits[w].exact && is_band_wedge(mesh, T, W, feat, w)) {
        band[w] = 1;
        fits[w] = fit_band_wedge(mesh, T, W, feat, w, feature_fit_degree(p, opt), fits[w], opt);
      }
  });
  long long count = 0;
  for (char b : band) count += b;
  return count;
}

}  // namespace hocurve
