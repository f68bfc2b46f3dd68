// Exact quadrics through mesh vertices: a CAD mesher puts its vertices on the exact surface, and
// planes, spheres, cylinders, cones and ellipsoids are quadrics. Where the vertices round an edge
// lie on one smooth quadric to rounding, the edge is a chord of that surface, however far it
// turns (a coarse mesh of a cylinder), not a crease. Tori are no quadrics but Darboux cyclides
// (quartics of the form quadric + |y|^2 b.y + a |y|^4), tried where no quadric fits.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <vector>

namespace hocurve {

struct Wedges;
struct StencilScratch;

/// An implicit quadric q(y) = c . (y1^2, y2^2, y3^2, y1 y2, y2 y3, y3 y1, y1, y2, y3, 1) = 0 in
/// normalised coordinates y = (x - centre) / scale, |c| = 1; or a Darboux cyclide, the quadric
/// plus c10..12 |y|^2 y + c13 |y|^4: tori (CAD fillets, rounded rims), Dupin cyclides.
struct ExactQuadric {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double scale = 1;
  Eigen::Matrix<double, 14, 1> c = Eigen::Matrix<double, 14, 1>::Zero();
  double max_residual = 0;  ///< largest first-order distance |q| / |grad q| of a point, world units
  /// The same for the runner-up (the next eigenvector): about max_residual where the points lie
  /// on more than one quadric (two circles, two lines), so that none is determined.
  double runner_up = 0;
  double tolerance = 0;     ///< the distance within which a point counts as on it (fit_region), world units
  bool valid = false;       ///< fitted (enough points, finite, determined)
  bool missed = false;      ///< no surface of the kind is within the fit's miss_bound of every point
  /// A cyclide's quartic terms, not a quadric.
  bool cyclide() const { return c.tail<4>().squaredNorm() > 0; }
  /// A plane: only the linear and constant terms.
  bool plane() const { return !cyclide() && c.head<6>().squaredNorm() == 0; }
  /// q at world point x.
  double value(const Eigen::Vector3d& x) const;
  /// First-order distance of x to the quadric, world units (infinite where the gradient is 0).
  double distance(const Eigen::Vector3d& x) const;
  /// x within tolerance of the quadric.
  bool contains(const Eigen::Vector3d& x) const { return distance(x) <= tolerance; }
  /// A point of the quadric near x: Newton steps along the gradient from x (x itself where the
  /// gradient vanishes).
  Eigen::Vector3d project(const Eigen::Vector3d& x) const;
  /// Gradient of q at world point x (normalised coordinates' gradient: only its direction and
  /// relative size matter).
  Eigen::Vector3d gradient(const Eigen::Vector3d& x) const;
};

/// Least-squares implicit quadric through the points (rows of P, at least 12): the smallest
/// eigenvector of the monomials' normal matrix. planes: points within 1e-3 x their spread of a
/// plane (at least 4) get that plane. valid: fitted, finite (whether it fits is the caller's).
/// miss_bound: where a cheap test shows that no quadric is within it (world units) of every point,
/// no fit (missed, max_residual infinite).
ExactQuadric fit_exact_quadric(const Eigen::MatrixXd& P, bool planes = false,
                               double miss_bound = std::numeric_limits<double>::infinity());

/// The least-squares sphere (or plane) through the points (rows of P, at least 6), as
/// fit_exact_quadric on the monomials |y|^2, y, 1; the runner-up is the next sphere. Why: a coarse
/// cap (a fan of 6-8 triangles) has too few points for a quadric, and its circle and apex lie on
/// many (a sphere, paraboloids, a cone), of which the sphere is the CAD face.
ExactQuadric fit_exact_sphere(const Eigen::MatrixXd& P);

/// The same for Darboux cyclides (at least 16 points). Points on a sphere or a plane lie on
/// many cyclides (the sphere times any sphere), so try the quadric first.
ExactQuadric fit_exact_cyclide(const Eigen::MatrixXd& P, double miss_bound = std::numeric_limits<double>::infinity());

/// The quadric through the points P whose gradient at the points X (rows) is along the normals N
/// (rows): least squares of both, the smallest eigenvector as above. max_residual and runner_up
/// count a normal's miss as its angle (sine) x scale. Where a strip between exact surfaces (a
/// fillet two triangles across) has too few points to determine its quadric, the normals along
/// its rims, where it is tangent to them, do.
ExactQuadric fit_tangent_quadric(const Eigen::MatrixXd& P, const Eigen::MatrixXd& X, const Eigen::MatrixXd& N);

/// The same for Darboux cyclides: a torus fillet between a cylinder and a plane, its points one
/// or two rows across, is determined by them with the normals along both rims.
ExactQuadric fit_tangent_cyclide(const Eigen::MatrixXd& P, const Eigen::MatrixXd& X, const Eigen::MatrixXd& N);

/// Q is a pair of planes (its 4 x 4 symmetric matrix of rank 2, its quadratic part not 0): the
/// vertices of a plane and of a strip beside it (a fillet's other two rows) lie on one, though
/// no CAD face is one.
bool plane_pair(const ExactQuadric& Q);

/// Q is a cyclide without its |y|^4 term (to rounding): a cubic surface, such as a plane times a
/// sphere. The points of a plane cap and of a torus fillet one triangle across beside it lie on one
/// (the cap's plane, and the sphere through the fillet's far rim and one more point), which is no
/// CAD face: a rounded cylinder at Gmsh's sizes had wedges on such, 57 degrees off the torus.
/// "To rounding": |c13| <= 1e-10 |c| (those were 4e-14 to 3e-13; a torus has c13 ~ 1 at its own
/// scale, and ~ (stencil / R)^3 on a stencil much smaller than its radius R).
bool plane_sphere(const ExactQuadric& Q);

/// Q is a sphere, a circular cylinder or a circular cone, to rounding (1e-6 of its largest
/// curvature): the surfaces a CAD part's holes, bosses and domes are. Points on three coaxial
/// circles always lie on one quadric of revolution, but on these only where the part is round.
bool round_primitive(const ExactQuadric& Q);

/// plane_pair or plane_sphere: a product of simpler surfaces, which no single CAD face is.
bool reducible(const ExactQuadric& Q);

/// Relative rounding of the mesh's coordinates: 2^-24 where all are float32 (binary STL), else
/// half a unit in the last of the fewest decimal digits that give back sampled coordinates
/// (text formats), at least double epsilon.
double coordinate_rounding(const Mesh& mesh);

struct ExactQuadricOptions {
  int rings = 3;                  ///< face rings grown round an edge; most rings of a wedge's stencil
  int wedge_points = 16;          ///< a wedge's stencil grows until it has this many vertices
  /// ... and where it fits, the quadric must fit a stencil grown to this many (2 rings more at
  /// most) too: a smooth surface's deviation from the quadric nearest it grows as the cube of the
  /// stencil's size, rounding does not (a marching-tetrahedra torus at grid 40 had 6 wedges within
  /// 1-8x rounding of a quadric over 16 points: P4 3.2e-6 -> 7.8e-6; over 40 points, none).
  int confirm_points = 40;
  /// ... or the vertices on it connected to the wedge's must number this many and end where the
  /// next are clearly off it, by clear_factor x the tolerance (a crease or a tangent junction:
  /// region_ends_clearly in exact_quadric.cpp); then the fit is shared with the wedges round it
  /// whose faces lie on it (share_exact_fits).
  int region_points = 32;
  double clear_factor = 100;
  /// A face lies on a neighbour's exact surface (share_exact_fits.hpp: face_on) where its corners
  /// are within this x the surface's tolerance: the surface was fitted to other points, and at a
  /// junction rim beyond them it extrapolates (a float32 filleted box at h = 0.1: rim corners
  /// 1.04x the tolerance off their fillet's cylinder, which 80 faces then did not take).
  double on_factor = 2;
  /// The region does not cross edges turning by more than this factor x the tested edge's
  /// dihedral angle + 15 degrees: the creases round a coarse smooth face turn further than its
  /// chords (a cylinder's rim 80-90 degrees, a six-segment side's 23-38).
  double wall_factor = 1.5;
  /// Points must lie within tolerance x rounding x their largest coordinate norm of the quadric.
  double tolerance = 8;
  /// The input's relative coordinate rounding (coordinate_rounding; 0: float32's 2^-24, a binary
  /// STL's); taken as at least 1e-8: a CAD kernel's curves between two faces are approximations
  /// (OpenCASCADE's to about 1e-7), and so are the positions of the vertices on them (Gmsh's tee
  /// and cylinder with a cross hole from a full-precision ASCII STL, at 1e-10: P4 30-70x worse).
  double rounding = 0;
  /// ... and the runner-up quadric must miss some point by unique x the tolerance: points on two
  /// circles lie on a cylinder and on every sphere and hyperboloid through both (t13's 48 mm
  /// walls between two fillets bulged 3 mm on one).
  double unique = 1000;
  /// The same for cyclides, whose 13 unknowns fit more: five coaxial circles (a revolved CAD
  /// export's rings) lie on one cyclide of revolution. King's profile got 26 false ones at 1000
  /// (0.50% -> 0.67% off the input); the tori of CAD parts are determined 10^4 - 10^6 x over.
  double unique_cyclide = 1e4;
  /// ... but only this where the tolerance is within cyclide_precision x the points' extent: there
  /// 16-52 points within 2e-6 of their extent lie on one cyclide by design, and the next one
  /// missing some point by 10x the tolerance tells it apart (a sphere's points lie within rounding
  /// of a whole family of cyclides). A small part of a torus beside its axis (screw.step's dome,
  /// its tube radius 6.7x its axis radius, next to the apex) lies within 15-350x the tolerance of
  /// a second cyclide however many points it has. The screw at d/40, d/80, d/160, P4: 9.0e-3 /
  /// 3.5e-4 / 2.5e-4 at 100, 3.3e-4 / 3.5e-4 / 1.2e-4 at 10 (no other of 91 inputs changes);
  /// at 3 a CAD export (ktoolcav) and T20 at d/20 change too.
  double unique_cyclide_precise = 10;
  /// Where that holds: the screw's dome regions 2e-6 (float32, coordinates ~ 5x the region);
  /// king's seven-digit text reaches 5e-6 on its largest regions, whose cyclides then took P6
  /// 0.44% -> 0.49% off the input.
  double cyclide_precision = 3e-6;
  /// A wedge off the features tries its exact quadric only where one of its faces turns from its fit's normal by
  /// more than this (degrees; local_fit.cpp): below, a degree-4 polynomial fits to about
  /// (2 degrees in radians)^5 h = 5e-8 h, and the test would only cost time (the 200k-triangle
  /// sphere, 0.7 degrees per edge: 0.75 s more).
  double min_turn_deg = 2;
  /// tolerance x rounding (0: 2^-24, at least 1e-8).
  double relative_tolerance() const { return tolerance * std::max(rounding > 0 ? rounding : 0x1p-24, 1e-8); }
  /// Every region face's normal within this angle (degrees) of the quadric's normal at its
  /// corners, all on one side: a cylinder's flat cap with no inner vertex has its corners on the
  /// cylinder too, but its normal is square to it.
  double max_normal_angle_deg = 60.0;
  /// The quadric's gradient at the edge's ends at least this x its largest in the region: a
  /// crease between two planes lies on their product, singular along the crease.
  double min_gradient_ratio = 0.1;
  /// A closed fan's sphere (fan_sphere) needs the tolerance within this x the fan's size: its 6-8
  /// corners are only 2-4 more than a sphere's unknowns, and at a text file's six digits scans'
  /// fans lay on spheres (tolerance / size 2e-4 to 1e-3: spot, boot, armadillo, both bunnies).
  /// A float32 CAD mesh's coarse caps: 1.5e-7; T20's (coordinates ~160): 1.1e-5.
  double fan_sphere_precision = 2e-5;
  /// Where the points lie on no quadric, try a Darboux cyclide: a torus is one, and CAD fillets
  /// and rounded rims are tori. A wedge fits it on its confirm_points stencil (13 unknowns).
  bool cyclides = true;
};

/// Q is the surface of the points it was fitted to: valid, within `tolerance` of every one, and
/// determined by them (the next-best fit misses by opt.unique x tolerance, opt.unique_cyclide for
/// cyclides, whose extra terms fit more point sets; opt.unique_cyclide_precise where the
/// tolerance is within opt.cyclide_precision x `size`, the points' extent (bounding box diagonal), when
/// given).
bool determined(const ExactQuadric& Q, double tolerance, const ExactQuadricOptions& opt, double size = 0);

/// True when face f's normal is within opt.max_normal_angle_deg of Q's at each of its corners, on
/// the side given (side 0: set to that of the first corner).
bool face_agrees(const Mesh& mesh, int f, const ExactQuadric& Q, const ExactQuadricOptions& opt, double& side);

/// True when interior edge e (dihedral angle theta, degrees) lies inside a region of vertices on
/// one exact, regular quadric or cyclide whose normals agree with the faces' (ExactQuadricOptions), and
/// not every face of the region has a coplanar neighbour (a prism's flat sides, two triangles
/// each, have their corners on a cylinder too). Else, when the closed fan of one of its ends has a
/// sphere (fan_sphere). face_angle: per Topology edge, the dihedral angle in
/// degrees (0 for boundary edges). min_wall_deg: the region crosses edges turning by less than this
/// whatever e's angle (a junction test's edges turn by little, the chords round them by more).
bool edge_on_exact_quadric(const Mesh& mesh, const Topology& T, int e, const std::vector<double>& face_angle,
                           const ExactQuadricOptions& opt = {}, double min_wall_deg = 0);

/// The sphere of the closed fan round vertex v (valid false if none, or v on the boundary): its corners
/// on one to the tolerance and determining it (fit_exact_sphere; 6 corners at least), the
/// tolerance within opt.fan_sphere_precision x the fan's size, regular at v, no two adjacent faces
/// coplanar, every face's normal along it. Why a fan: a coarse cap's apex (a fan of 6-8
/// triangles, inside a shallow crease or a tangent junction) has too few points for a quadric, and
/// its circle and apex lie on many (paraboloids, a cone), of which the sphere is the CAD face.
ExactQuadric fan_sphere(const Mesh& mesh, const Topology& T, int v, const ExactQuadricOptions& opt);

/// Per edge, 1 where candidate[e] and edge_on_exact_quadric (TBB-parallel). Not repeated with
/// the edges found not on one as walls: a revolved CAD export's profile creases then bounded
/// regions of three coaxial circles, which always lie on a quadric of revolution (king: P6 0.44
/// -> 0.49% off the input).
std::vector<char> exact_quadric_edges(const Mesh& mesh, const Topology& T, const std::vector<double>& face_angle,
                                      const std::vector<char>& candidate, const ExactQuadricOptions& opt = {});

/// The plane of wedge w's faces where their corners lie on one to the tolerance (valid false if
/// not): a plane's first row of vertices beside a fillet, whose stencils reach into it.
ExactQuadric wedge_plane(const Mesh& mesh, const Wedges& W, int w, const ExactQuadricOptions& opt);

/// The exact quadric or plane of wedge w (valid false if none): through the vertices of its stencil (not
/// across features; grown until it holds wedge_points, then confirmed on confirm_points), regular
/// at its vertex, every stencil face's normal agreeing with it. Else its cyclide, on either
/// stencil (on the larger where the smaller has too few points or does not determine it). Else,
/// for a wedge that is its vertex's whole closed fan (no feature through it, no cone point), the fan's
/// sphere (fan_sphere).
ExactQuadric wedge_exact_quadric(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                                 const ExactQuadricOptions& opt, StencilScratch& scratch);

}  // namespace hocurve
