// Exact fits shared across tangent junctions: a wedge whose stencil spans two CAD faces (the
// vertices beside a fillet, or a half sphere's first row above its cylinder) lies on no single
// quadric, but its own faces may all lie on a neighbour's.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/exact_quadric.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"

#include <memory>
#include <vector>

namespace hocurve {

/// The exact surface as the fit of the wedge whose height fit is `fit` (its vertex o, scale h):
/// the frame's normal is the surface's at o, on the side of fit.n.
LocalFit exact_surface_fit(std::shared_ptr<const ExactQuadric> surface, const LocalFit& fit, int p);

/// True when every corner of wedge w's faces lies on Q (within its tolerance) and every face's
/// normal is within opt.max_normal_angle_deg of Q's at its corners, all on one side.
bool wedge_faces_on(const Mesh& mesh, const Wedges& W, int w, const ExactQuadric& Q, const ExactQuadricOptions& opt);

/// Wedges without an exact fit (and no cone model) whose faces all lie on the exact surface of a
/// wedge sharing one of their faces take that surface, repeated until none does (each round reads
/// the last one's fits only: deterministic). Returns how many took one.
long long share_exact_fits(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt, std::vector<LocalFit>& fits);

/// Wedges still without an exact fit whose faces' corners lie on a quadric tangent, at those of
/// them on another exact surface, to that surface (a fillet two triangles across between planes,
/// a corner sphere between fillets: too few points of their own to determine it) take that
/// quadric; then share_exact_fits; repeated until none does. Returns how many took one either way.
long long tangent_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const ExactQuadricOptions& opt,
                             std::vector<LocalFit>& fits);

}  // namespace hocurve
