#include "engine/curving/share_exact_fits.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <numbers>

namespace hocurve {

LocalFit exact_surface_fit(std::shared_ptr<const ExactQuadric> surface, const LocalFit& fit, int p) {
  LocalFit F;
  F.surface = std::move(surface);
  F.o = fit.o;
  F.h = fit.h;
  F.n = F.surface->gradient(F.o).normalized();
  if (F.n.dot(fit.n) < 0) F.n = -F.n;
  tangent_frame(F.n, F.t1, F.t2);
  F.exact = true;
  F.degree = F.requested_degree = p;
  F.c = Eigen::VectorXd::Zero(fit_coefficients(p));
  F.pivot_ratio = 1;
  return F;
}

bool wedge_faces_on(const Mesh& mesh, const Wedges& W, int w, const ExactQuadric& Q, const ExactQuadricOptions& opt) {
  const double min_cos = std::cos(opt.max_normal_angle_deg * std::numbers::pi / 180.0);
  double side = 0;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d n = face_normal(mesh, f).normalized();
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d x = mesh.V.row(mesh.F(f, j)).transpose();
      if (!Q.contains(x)) return false;
      const double c = n.dot(Q.gradient(x).normalized());
      if (side == 0) side = c > 0 ? 1 : -1;
      if (!(side * c >= min_cos)) return false;
    }
  }
  return side != 0;
}

long long share_exact_fits(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt, std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  long long shared = 0;
  std::vector<int> from(nw);
  for (bool changed = true; changed;) {
    std::fill(from.begin(), from.end(), -1);
    tbb::parallel_for(tbb::blocked_range<int>(0, nw, 256), [&](const tbb::blocked_range<int>& r) {
      for (int w = r.begin(); w < r.end(); ++w) {
        if (fits[w].exact || fits[w].apex || W.is_cone(W.wedge_vertex[w])) continue;
        for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1] && from[w] < 0; ++i)
          for (int j = 0; j < 3 && from[w] < 0; ++j) {
            const int u = W.corner_wedge(W.wedge_faces[i], j);
            if (u != w && fits[u].exact && wedge_faces_on(mesh, W, w, *fits[u].surface, opt)) from[w] = u;
          }
      }
    });
    changed = false;
    for (int w = 0; w < nw; ++w)
      if (from[w] >= 0) {
        fits[w] = exact_surface_fit(fits[from[w]].surface, fits[w], fits[w].requested_degree);
        changed = true;
        ++shared;
      }
  }
  return shared;
}

}  // namespace hocurve
