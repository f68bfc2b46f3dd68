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

/// True when face f's corners lie on Q (within opt.on_factor x its tolerance; with W, a corner on a
/// feature curve within opt.clear_factor x it) and its normal is within opt.max_normal_angle_deg of
/// Q's at each, on the side given (side 0: set to that of the first). Why feature corners apart: a
/// CAD kernel's curves between two faces are only within the file's tolerance of them, and Gmsh
/// puts the rim's vertices on the curve (screw.step: a slot's rim 12x the tolerance off the dome).
bool face_on(const Mesh& mesh, int f, const ExactQuadric& Q, const ExactQuadricOptions& opt, double& side,
             const Wedges* W = nullptr);

/// True when every corner of wedge w's faces lies on Q (face_on, feature corners apart) and every face's
/// normal is within opt.max_normal_angle_deg of Q's at its corners, all on one side.
bool wedge_faces_on(const Mesh& mesh, const Wedges& W, int w, const ExactQuadric& Q, const ExactQuadricOptions& opt);

/// Wedges without an exact fit (and no cone model) whose faces all lie on the exact surface of a
/// wedge sharing one of their faces take that surface, repeated until none does (each round reads
/// the last one's fits only: deterministic). Returns how many took one.
long long share_exact_fits(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt, std::vector<LocalFit>& fits);

/// The exact surfaces of wedges joined by their faces (two wedges join where each one's surface
/// holds a face at both, face_on, or both hold the same surface: one CAD face), refitted to the
/// corners of all the group's faces where that fit is determined, has every face's normal along it
/// and is of the same kind (plane, quadric, cyclide) as the first wedge's; the group's wedges then
/// hold the refit. Why: a wedge takes a neighbour's surface where its corners are within twice the
/// tolerance of it (share_exact_fits), and a surface fitted to one stencil drifts by about that
/// much where it is extrapolated: a float32 torus at h = 0.05 had 3074 wedges on shared cyclides
/// and nodes 6-7e-7 off (P4 7.7e-7; 7.1e-8 before sharing, 6.4e-8 refitted as one surface).
/// Returns how many surfaces were refitted.
long long refit_shared_surfaces(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt,
                                std::vector<LocalFit>& fits);

/// Per face whose corners' fits are not all exact, those that are not all of wedges whose faces
/// turn by more than opt.min_turn_deg (or one-sided: where a wedge tries its own): the exact fit, among those of the wedges of the
/// faces round its corners, whose surface holds the face (face_on), where all that do agree on its
/// centroid to clear_factor x their tolerance (else, and for every other face, null). Why: at a
/// tangent junction a wedge's fan spans two CAD faces and no exact fit of its own, so a face whose
/// corners all lie on junction curves (a filleted box's corner sphere at h = 0.1, between its
/// fillets) had its nodes blended from fits across the junction, though a neighbour's exact fit
/// holds it.
std::vector<const LocalFit*> face_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W,
                                             const std::vector<LocalFit>& fits, const ExactQuadricOptions& opt);

/// Wedges still without an exact fit whose faces' corners lie on a quadric tangent, at those of
/// them on another exact surface, to that surface (a fillet two triangles across between planes,
/// a corner sphere between fillets: too few points of their own to determine it) take that
/// quadric; then share_exact_fits; repeated until none does. Then each region of faces that no
/// exact fit holds, joined across smooth edges, fits the quadric or cyclide through its corners
/// tangent to the exact surfaces at those on them (a torus fillet two rows across, whose middle
/// row's fans alone do not determine it), which the wedges whose faces all lie on it take; and
/// the whole again while any wedge takes one. Returns how many took one in every way.
long long tangent_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const ExactQuadricOptions& opt,
                             std::vector<LocalFit>& fits);

}  // namespace hocurve
