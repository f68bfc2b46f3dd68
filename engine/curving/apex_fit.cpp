#include "engine/curving/apex_fit.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

namespace {

/// Basis of the apex model at (rho, phi), its first n columns (LocalFit::apex).
void apex_row(double rho, double phi, int n, double* row) {
  const double c1 = std::cos(phi), s1 = std::sin(phi), c2 = std::cos(2 * phi), s2 = std::sin(2 * phi);
  const double all[8] = {rho, rho * c1, rho * s1, rho * c2, rho * s2, rho * rho, rho * rho * c1, rho * rho * s1};
  for (int j = 0; j < n; ++j) row[j] = all[j];
}

/// Slope g and curvature k of the model's ruling at azimuth phi (LocalFit::apex).
void ruling(const Eigen::VectorXd& c, double phi, double& g, double& k) {
  double row[8];
  apex_row(1, phi, static_cast<int>(c.size()), row);
  g = k = 0;
  for (Eigen::Index j = 0; j < c.size(); ++j) (j < 5 ? g : k) += c[j] * row[j];
}

}  // namespace

Eigen::Vector3d LocalFit::apex_project(const Eigen::Vector3d& x) const {
  const Eigen::Vector3d d = (x - o) / h;
  const double z = d.dot(n);
  const Eigen::Vector3d r = d - z * n;
  const double rho = r.norm();
  if (!(rho > 1e-12)) return o;
  double g, k;
  ruling(c, std::atan2(r.dot(t2), r.dot(t1)), g, k);
  // Onto the ruling in the meridian half-plane orthogonally (steep cones too), then the
  // curvature term at that distance.
  const double t = std::max((rho + g * z) / (1 + g * g), 0.0);
  return o + h * ((t / rho) * r + (g * t + k * t * t) * n);
}

Eigen::Vector3d LocalFit::apex_point(const Eigen::Matrix3d& P, const Eigen::Vector3d& xi) const {
  double rho = 0, phi = 0, phi_weight = 0, phi_ref = 0;
  bool have_ref = false;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d d = (P.row(j).transpose() - o) / h;
    const Eigen::Vector3d r = d - d.dot(n) * n;
    const double rj = r.norm();
    rho += xi[j] * rj;
    if (!(rj > 1e-9) || xi[j] == 0.0) continue;
    double pj = std::atan2(r.dot(t2), r.dot(t1));
    if (!have_ref) phi_ref = pj, have_ref = true;
    pj = phi_ref + std::remainder(pj - phi_ref, 2 * std::numbers::pi);
    phi += xi[j] * pj;
    phi_weight += xi[j];
  }
  if (!(phi_weight > 0)) return o;
  phi /= phi_weight;
  double g, k;
  ruling(c, phi, g, k);
  return o + h * (rho * (std::cos(phi) * t1 + std::sin(phi) * t2) + (g * rho + k * rho * rho) * n);
}

LocalFit fit_apex(const Mesh& mesh, const Topology& T, const Wedges& W, int w, const FitOptions& opt) {
  StencilOptions so;
  so.min_rings = so.max_rings = opt.apex_rings;
  so.target_points = 0;
  const Stencil S = grow_stencil(mesh, T, W, w, so);
  LocalFit fit = fit_cone_model(mesh, T, W.wedge_vertex[w], std::vector<int>(S.vertices.begin() + 1, S.vertices.end()),
                                opt.apex_max_residual);
  fit.rings = S.rings;
  return fit;
}

LocalFit fit_cone_model(const Mesh& mesh, const Topology& T, int v, const std::vector<int>& points, double max_residual) {
  LocalFit fit;
  fit.o = mesh.V.row(v).transpose();
  fit.identity = true;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double h = 0;
  int n1 = 0;
  for (auto [fb, fe] = T.faces_of(v); fb != fe; ++fb) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(*fb, 0)), b = mesh.V.row(mesh.F(*fb, 1)), c = mesh.V.row(mesh.F(*fb, 2));
    normal += (b - a).cross(c - a);
  }
  for (auto [eb, ee] = T.edges_of(v); eb != ee; ++eb, ++n1) h += (mesh.V.row(T.other(*eb, v)).transpose() - fit.o).norm();
  if (n1 == 0 || !(normal.norm() > 0) || !(h > 0)) return fit;
  fit.h = h / n1;
  fit.n = normal.normalized();
  fit.t1 = fit.n.unitOrthogonal();
  fit.t2 = fit.n.cross(fit.t1);
  const int m = static_cast<int>(points.size());
  // Start from the mean direction of the points seen from the apex (a cone's axis where they
  // surround it evenly; the fan normal leans far off it under an uneven fan of three triangles).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < m; ++i) mean -= (mesh.V.row(points[i]).transpose() - fit.o).normalized();
  if (mean.norm() > 1e-3 * m) {
    fit.n = mean.dot(fit.n) >= 0 ? mean.normalized() : Eigen::Vector3d(-mean.normalized());
    fit.t1 = fit.n.unitOrthogonal();
    fit.t2 = fit.n.cross(fit.t1);
  }
  const int n = m >= 16 ? 8 : m >= 10 ? 5 : m >= 6 ? 3 : 0;
  if (n == 0) return fit;
  Eigen::MatrixXd A(m, n);
  Eigen::VectorXd z(m);
  double rms = 0;
  // The fan normal leans off a cone's axis where the fan is uneven: each round tilts it by the
  // fit's first harmonic of the slope (a tilt e adds e (1 + g^2) cos(phi - phi0) to it).
  for (int round = 0; round < 4; ++round) {
    for (int i = 0; i < m; ++i) {
      const Eigen::Vector3d d = (mesh.V.row(points[i]).transpose() - fit.o) / fit.h;
      const double zi = d.dot(fit.n);
      const Eigen::Vector3d r = d - zi * fit.n;
      double row[8];
      apex_row(r.norm(), std::atan2(r.dot(fit.t2), r.dot(fit.t1)), n, row);
      for (int j = 0; j < n; ++j) A(i, j) = row[j];
      z[i] = zi;
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    qr.setThreshold(1e-8);  // points on a few azimuths only do not determine the harmonics
    if (qr.rank() < n) return fit;
    fit.c = qr.solve(z);
    rms = std::sqrt((A * fit.c - z).squaredNorm() / m);
    if (round == 3) break;
    const double g = fit.c[0];
    fit.n = (fit.n - (fit.c[1] * fit.t1 + fit.c[2] * fit.t2) / (1 + g * g)).normalized();
    fit.t1 = fit.n.unitOrthogonal();
    fit.t2 = fit.n.cross(fit.t1);
  }
  fit.residual = rms;
  fit.points = m;
  if (!(rms <= max_residual)) return fit;
  fit.identity = false;
  fit.apex = true;
  fit.pivot_ratio = 1;  // not a polynomial: nothing for the high-degree refit to lower
  return fit;
}

int share_apex_fits(const Topology& T, const Wedges& W, const FitOptions& opt, std::vector<LocalFit>& fits) {
  std::vector<int> near;
  std::vector<char> seen(W.vertex_wedge_start.size() - 1, 0);
  for (int w = 0; w < W.num_wedges(); ++w) {
    const int v = W.wedge_vertex[w];
    if (!W.is_cone(v) || !fits[w].apex) continue;
    near.assign(1, v);
    seen[v] = 1;
    for (int ring = 0, begin = 0; ring < opt.apex_share_rings; ++ring) {
      const int end = static_cast<int>(near.size());
      for (int i = begin; i < end; ++i)
        for (auto [eb, ee] = T.edges_of(near[i]); eb != ee; ++eb) {
          const int u = T.other(*eb, near[i]);
          if (seen[u] || W.vertex_wedges(u) != 1 || W.is_cone(u)) continue;
          seen[u] = 1;
          near.push_back(u);
          const int uw = W.vertex_wedge_start[u];
          const int requested = fits[uw].requested_degree;
          fits[uw] = fits[w];
          fits[uw].requested_degree = requested;
        }
      begin = end;
    }
    for (int u : near) seen[u] = 0;
  }
  return static_cast<int>(std::count_if(fits.begin(), fits.end(), [](const LocalFit& f) { return f.apex; }));
}

}  // namespace hocurve
