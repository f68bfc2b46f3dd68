// Synthetic analytic meshes with their exact distance / closest-point functions, shared by the
// tests and benchmarks: every vertex lies on the analytic surface (to rounding), so fit errors
// can be measured against the exact surface.
#pragma once
#include "engine/core/mesh.hpp"

#include <Eigen/Core>
#include <cstdint>
#include <functional>

namespace hocurve {

// --- meshes (counter-clockwise seen from outside, one entity unless stated) -------------------

/// Unit icosphere: icosahedron subdivided `subdivisions` times (20*4^s faces), vertices on |x|=1.
Mesh icosphere(int subdivisions);

/// Unit latitude-longitude sphere: nlat bands (>=2), nlon meridians (>=3), triangle fans at the
/// poles. With even nlat a ring of vertices lies on the equator z=0. Entity 1 is z>0, 2 is z<0,
/// so the equator is an entity border.
Mesh uv_sphere(int nlat, int nlon);

/// Torus around the z axis, major radius R, minor radius r: n_major x n_minor quad grid split in
/// two triangles per quad.
Mesh torus_grid(int n_major, int n_minor, double R, double r);

/// Ellipsoid x^2/a^2 + y^2/b^2 + z^2/c^2 = 1: icosphere mapped by diag(a,b,c), then radially
/// projected so that each vertex satisfies the equation to rounding.
Mesh ellipsoid_mesh(int subdivisions, double a, double b, double c);

/// Closed cylinder around the z axis, z in [-height/2, height/2]: n_around x n_height side grid
/// (entity 1), caps as fans around a centre vertex (entity 2 bottom, 3 top). Rims are sharp (90°).
Mesh capped_cylinder(int n_around, int n_height, double radius, double height);

/// CAD-export-like capped cylinder: the side is one row of long strips (n_height = 1), as
/// tessellators of B-reps produce; strongly non-uniform for large height.
Mesh capped_cylinder_cad(int n_around, double radius, double height);

/// Closed cone around the z axis: apex (0, 0, height), base circle of the given radius at z = 0.
/// The side is n_rings rings of n_around vertices below a fan at the apex (entity 1); the base is
/// a fan around its centre (entity 2). The apex is a cone point: no sharp edge meets it.
Mesh cone_mesh(int n_rings, int n_around, double radius, double height);

/// Projects a point onto an analytic surface (returns the closest surface point).
using Projector = std::function<Eigen::Vector3d(const Eigen::Vector3d&)>;

/// Moves every vertex by a seeded random offset of length <= amount * (mean incident edge
/// length), then projects it back with `project`. Deterministic for a seed.
void jitter_on_surface(Mesh& mesh, double amount, std::uint64_t seed, const Projector& project);

// --- exact signed distances (negative inside) and closest points -------------------------------

/// Signed distance to the unit sphere.
double sphere_distance(const Eigen::Vector3d& p);
Eigen::Vector3d sphere_closest(const Eigen::Vector3d& p);

/// Signed distance to the torus around z with radii R > r.
double torus_distance(const Eigen::Vector3d& p, double R, double r);
Eigen::Vector3d torus_closest(const Eigen::Vector3d& p, double R, double r);

/// Closest point on the ellipsoid with semi-axes (a,b,c): Newton on the Lagrange multiplier in
/// the monotone bracket, with the degenerate (medial-axis) cases handled explicitly.
Eigen::Vector3d ellipsoid_closest(const Eigen::Vector3d& p, double a, double b, double c);
/// Signed distance to that ellipsoid.
double ellipsoid_distance(const Eigen::Vector3d& p, double a, double b, double c);

/// Signed distance to the closed capped cylinder of capped_cylinder() (z in [-h/2, h/2]).
double capped_cylinder_distance(const Eigen::Vector3d& p, double radius, double height);
Eigen::Vector3d capped_cylinder_closest(const Eigen::Vector3d& p, double radius, double height);

/// Signed distance to the closed cone of cone_mesh().
double cone_distance(const Eigen::Vector3d& p, double radius, double height);

}  // namespace hocurve
