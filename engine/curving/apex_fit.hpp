// The surface round a cone point (the apex of a cone, Features::vertex_cone) as a cone: no
// polynomial height function fits a point singularity, a cone model does.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"

namespace hocurve {

/// Cone model of vertex v (LocalFit::apex): about an axis n through v, a point at distance rho
/// from the axis, azimuth phi and height z along n lies on z = rho g(phi) + rho^2 k(phi), g and
/// k short Fourier series, fitted by least squares to `points` (vertices other than v); the axis
/// starts at the mean direction from the points to v and turns until g has no first harmonic
/// (a circular cone's axis). An identity fit (apex false) where the points are too few or the
/// model misses them by more than max_residual x h (RMS; h the mean edge length at v).
LocalFit fit_cone_model(const Mesh& mesh, const Topology& T, int v, const std::vector<int>& points, double max_residual);

/// fit_cone_model of wedge w's vertex, a cone point, on its FitOptions::apex_rings stencil (not
/// across features or other cone points), kept within FitOptions::apex_max_residual.
LocalFit fit_apex(const Mesh& mesh, const Topology& T, const Wedges& W, int w, const FitOptions& opt);

/// The wedges within FitOptions::apex_share_rings of a cone point (off the features) take its
/// model where it is not the identity. Returns how many wedges hold a cone model then.
int share_apex_fits(const Topology& T, const Wedges& W, const FitOptions& opt, std::vector<LocalFit>& fits);

}  // namespace hocurve
