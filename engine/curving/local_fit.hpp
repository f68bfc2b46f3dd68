// Per-vertex weighted least-squares height-function fits (the "local fittings" of SOLF).
// Each wedge of each vertex gets a polynomial f(u, v) over its tangent plane that passes
// through the vertex (interpolatory: no constant term), fitted to the stencil's vertices.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/exact_quadric.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/curving/support_points.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <memory>
#include <vector>

namespace hocurve {

/// Row weights of the least-squares system.
/// Gaussian: exp(-d^2 / 2 sigma^2) (the SOLF paper's MLS weight);
/// InverseDistance: (d^2 / mean d^2 + 0.01)^(-p/2) (MOAB's WALF weight).
enum class WeightKind { Gaussian, InverseDistance };

struct FitOptions {
  WeightKind weight = WeightKind::Gaussian;
  /// sigma = max(sigma_factor * local mean edge length, sigma_reach * distance to the
  /// ceil(points_per_coef * #coefficients)-th nearest stencil vertex): fixed in h for low p,
  /// widened automatically where high p needs more points with weight.
  /// Measured (jittered sphere / torus / ellipsoid, 5k-11k triangles, L-inf, p2/p4/p6):
  ///   Gaussian 1.0 / 0.5, normal refined: 1.0e-5 2.2e-7 2.6e-8 | 4.5e-5 2.9e-6 8.8e-7 | 5.6e-5 2.4e-6 4.5e-7
  ///   MOAB inverse distance, no refine:   6.5e-6 8.2e-8 5.1e-9 | 3.9e-5 1.8e-6 1.4e-7 | 4.2e-5 1.6e-6 1.5e-7
  ///   Gaussian 0.75 / 0.35, no refine:    3.7e-6 3.4e-8 4.3e-9 | 5.1e-5 1.2e-6 2.1e-7 | 3.0e-5 1.4e-6 2.2e-7
  /// so the default is the last one (the SOLF weight, best or within 1.5x everywhere).
  double sigma_factor = 0.75;
  double sigma_reach = 0.35;
  double points_per_coef = 1.5;  ///< grow rings until #points >= this x #coefficients
  /// The same for one-sided wedges (vertices on features): their vertex sits on the edge of
  /// the data, where a least-squares fit is least accurate, and half a disc of rings holds half
  /// the points. Measured P4 (linear / hocurve max error) at 1.5 / 2.0 / 3.0: screw d/160
  /// 11.8 / 50 / 48, screw d/80 33 / 34 / 27, t20 and capped cylinder unchanged at 2.0.
  /// Also for vertices on an open boundary (one wedge, but a half disc): P4 at h = 0.2 / 0.1 /
  /// 0.05, quarter torus 6.1e-4 / 2.2e-5 / 1.2e-6 -> 1.7e-4 / 5.1e-6 / 2.0e-7; hemisphere from a
  /// float32 STL, whose rounding the half-disc fits amplified, 2.5e-7 / 3.9e-7 / 2.0e-6 -> 1.3e-7 /
  /// 4.9e-8 / 4.5e-8.
  double points_per_coef_one_sided = 2.0;
  /// The same for feature-curve fits (their Gaussian reaches the ceil(this x degree)-th nearest
  /// point of the chain). A chain has two points per ring, so 1.5 put sigma at 1.5 h and the
  /// fit reached three edges each way; on a curve that turns away from its reference circle (two
  /// cylinders crossing: 19 edges round the hole) P4 at h = 0.1 / 0.05 / 0.025 was 4.9e-5 /
  /// 2.3e-6 / 5.8e-8, now 2.1e-5 / 8.0e-7 / 2.3e-8 (0.5: 2.0e-5 / 7.5e-7 / 2.1e-8). Circles are
  /// fitted exactly either way; screw P6 d/40 1.03e-2 -> 9.1e-3; shared meshes unchanged.
  double curve_points_per_coef = 1.0;
  int max_rings = 6;
  int max_points = 128;
  /// Refit in the frame of the first fit's normal. Measured 1.3-3x LESS accurate than the
  /// area-weighted normal with the same weights (table above), so off by default.
  bool refine_normal = false;
  /// Refit one-sided wedges (vertices on features) in the refined normal's frame: their
  /// area-weighted normal is off by O(h). Measured on uv_sphere(24, 48) (equator border): P4
  /// 2.5e-4 without, 1.1e-5 with. Only when the first fit is well posed (on the CAD strips a
  /// refined normal breaks the exact two-row structure: 68x gain without, 1x with).
  bool refine_one_sided = true;
  /// Measure heights from the stencil's osculating torus instead of the tangent plane
  /// (LocalFit::k1, k2). Not for one-sided wedges (vertices on features): measured on the CAD
  /// screw and T20, their half-disc curvature estimates made P4 up to 10x worse.
  bool reference_torus = true;
  /// ... only from stencils of at least this many points: 4 per unknown of the curvature
  /// estimate (5). Smaller stencils (degree-2 and -3 fits) keep the plane: measured, their noisier
  /// references cost the observed order (jittered ellipsoid P3 3.59 with, 3.75 without).
  int reference_min_points = 20;
  /// Also fit over the stencil's quadric (quadric_reference, reference_fit) and keep it where it
  /// fits much better (quadric_gain). Measured (bench/accuracy.py, max error, h = 0.2 / 0.1 /
  /// 0.05): ellipsoid P4 1.06e-3 / 5.34e-5 / 2.21e-6 -> 5.7e-5 / 3.1e-6 / 1.7e-7 (at Gmsh's P4
  /// from the exact CAD: its nodes are exact, what is left is interpolation), P6 6.7e-4 / 3.2e-5 /
  /// 6.2e-7 -> 6.9e-6 / 1.1e-7 / 3.8e-8; sphere, torus, capped cylinder, screw, T20 unchanged.
  /// Keeping it whenever its residual was merely lower bulged a flat t13 strip (ratio 0.97) and
  /// cost torus h = 0.05 P4 1.2x.
  bool reference_quadric = true;
  /// Choose between the quadric and the other reference by their fits' leave-one-out residuals
  /// (leave_one_out_residual, quadric when below quadric_loo_gain x the other's) instead of the
  /// in-sample residuals with quadric_gain (still the gate for trying the quadric at all: tried
  /// whenever it merely fits better, on float32 input always, the fits took 2.4x as long).
  /// Measured (bench/accuracy.py, max error): CAD screw d/80, d/160 P4 1.62e-3 / 3.00e-4 -> 1.25e-3
  /// / 2.50e-4; the rest unchanged. Gain 1.0: torus h = 0.1 P4 3.5e-6 -> 4.0e-6; 0.5: screw d/80
  /// 1.85e-3 (worse than before).
  bool quadric_by_leave_one_out = true;
  double quadric_loo_gain = 0.7;
  /// ... when its residual is below quadric_gain x the torus fit's (and, to save the second
  /// solve where it cannot win, the quadric's own residual below quadric_gain x the torus
  /// quadratic's: not on spheres and cylinders, where both are exact).
  double quadric_gain = 0.5;
  /// One-sided wedges (vertices on features; no torus: see reference_torus) try the quadric too,
  /// when their stencil reached its points within max_rings (not a thin band between two curves,
  /// where the quadric is free across the band: T20 d/40 P4 7x worse), and keep it only if it
  /// moves no point of the wedge's faces by more than one_sided_quadric_gap x h from the plane
  /// fit (else it bends away on the data's open side: king P4 0.54% -> 2.7% of the diagonal).
  /// Measured P4 at h = 0.2 / 0.1 / 0.05: capped cylinder 6.9e-4 / 1.0e-5 / 2.2e-7 -> 9.0e-6 /
  /// 2.3e-8 / 2.3e-8, CAD screw d/80, d/160 0.95x, 0.91x; T20 and the shared meshes unchanged.
  bool one_sided_quadric = true;
  double one_sided_quadric_gap = 0.05;
  /// Let one-sided wedges whose stencil reached max_rings try the quadric too (see above: off).
  bool one_sided_quadric_in_bands = false;
  /// A one-sided wedge whose quadric fit those two gates refused still takes it where, at its
  /// faces' edge midpoints and centroids, the quadric fit is closer to the fits of the faces'
  /// other corners off the features (two-sided stencils, over their own torus or quadric) than
  /// its plane fit is, by at least this factor (0: never). Where the plane fit is poor the gap
  /// gate refuses every good quadric: a fillet strip between two CAD-face borders, whose
  /// one-sided plane fits of a 90 degree arc are 0.3 h off. Measured P4 (filleted box with its
  /// CAD faces as entities, h = 0.05): cylinders 1.05e-3 -> 1.3e-6, planes 6.1e-3 -> 2e-14, corner
  /// spheres 8.8e-4 -> 3.1e-5 (Gmsh's P4 from the CAD: 1.9e-6); skull deviation 0.477% -> 0.435%;
  /// king (0.460%, where the quadric bends away), screw, T20, capped cylinder and the other shared
  /// meshes unchanged.
  double one_sided_quadric_agreement = 0.5;
  /// The same agreement pass also offers every one-sided wedge its fit over the torus (or
  /// quadric) of its own half disc (reference_fit, as two-sided wedges fit). Where a curved strip
  /// turns 90 degrees between two feature curves (a fillet given as a CAD face), heights over the
  /// plane or the quadric at one border are singular at the other (the surface turns vertical):
  /// those fits were 0.05-0.08 h off their own points, the torus chart's arc lengths are not.
  /// The agreement is the distance from the candidate's surface points to the neighbours' fits
  /// (not between two projections of one point, which differ tangentially on curved strips).
  /// Measured P4 (bench/cad_sweep.py): cylinder with r = 0.12 rim fillets given as CAD faces,
  /// h = 0.05: 6.0e-3 (worse than linear, 4.0e-3) -> 2.2e-5; filleted box from the STL, h = 0.05:
  /// 3.1e-5 -> 7.5e-6; half torus h = 0.1 / 0.05: 2.2e-5 / 5.7e-7 -> 1.2e-5 / 3.0e-7; screw, T20,
  /// capped cylinder, cone, cut sphere, cross hole, capsule unchanged.
  bool one_sided_torus = true;
  /// Surface fits at features have degree at most feature_max_degree (feature_fit_degree()):
  /// one-sided wedges (fit_wedges) and band wedges (refit_band_wedges). At degree 6 a half-disc
  /// stencil needs 54 points, reaches max_rings (so no quadric) and wraps far round curved faces;
  /// a band's stencil wraps round a whole rim. Measured P6 at h = 0.2 / 0.1 / 0.05: capped
  /// cylinder 7.6e-3 / 2.2e-5 / 1.3e-7 -> 1.3e-5 / 2.1e-8 / 2.3e-8 (P4: 9.0e-6 / 2.3e-8 / 2.3e-8);
  /// CAD screw d/40 7.9e-2 -> 3.7e-2 (P4 4.0e-2); smooth shapes unaffected. With
  /// high_degree_condition below, the P6 deviation from the input (max over the bbox diagonal)
  /// of king 0.97% -> 0.52% (P4: 0.54%), t13 1.39% -> 1.33%, hinge 1.02% -> 0.43%. (Feature-curve
  /// fits keep degree p: at degree 4 for P6, the validity repair of a cap-fan sliver pulled a
  /// second arc edge off the stadium rim in test_solf_features.)
  int feature_max_degree = 4;
  /// Band wedges (band_fit.hpp) are also fitted along rulings up to this angle (degrees) from the
  /// direction across the band, and the ruled fit with the least residual is kept where it fits
  /// much better than the one across (0: across only). Scanned in band_ruling_step_deg steps, then
  /// refined by band_ruling_refinements golden-section steps round the best. Why: a cone's rulings
  /// meet a rim that is no circle about its axis obliquely (T20's nut chamfer between its top
  /// circle and the hex flats' hyperbolas: fits across the band 2.4e-2 off, along the rulings
  /// 2.5e-4; its rulings 5-35 degrees off). At 60, lever_solidedge's bands took rulings at 55
  /// degrees that fitted only 2.4-3x better and moved nodes by a fifth of an edge.
  double band_ruling_max_deg = 45;
  double band_ruling_step_deg = 10;
  int band_ruling_refinements = 6;
  /// ... kept where its weighted residual (units of the local edge length h) is at most
  /// band_ruled_residual, the band being ruled along them (T20's chamfer at d/20 / d/40: 4e-5 /
  /// 2e-5), and at most band_ruling_gain x the fit's across the band (T20: 0.03 - 0.3). Without
  /// them, bands that are no ruled surface (scans' and CAD exports' revolved profiles, 5e-3 - 5e-2
  /// along the best rulings, 0.1 - 0.3 across) or planar ones (any rulings fit to rounding) took
  /// rulings that only fit the noise: deviation from the input king 0.50% -> 1.47%, t13 1.3% ->
  /// 2.2%, ktoolcav 0.76% -> 1.9%; with them those are unchanged.
  double band_ruled_residual = 1e-3;
  double band_ruling_gain = 0.5;
  /// ... and only from stencils with this many points more than the ruled fit's unknowns (the
  /// angle is one more): bunny_closed's band stencils of 8 points for 8 unknowns, or 5 for 4, took
  /// any rulings, which moved the coarse lifting's dense surface (its re-decimated deviation 0.57%
  /// -> 0.72%). T20's chamfer stencils: 11 points for 8.
  int band_ruling_spare_points = 3;
  /// Fits above min_degree (P5, P6) whose pivot ratio is below this refit at min_degree: their
  /// top coefficients are barely determined and the fit wiggles between the points (CAD screw
  /// near the slot, pivots ~1e-3: 8x the degree-4 fit's error; on the torus at h = 0.2 they are
  /// 0.12-0.15). Measured P6, screw d/80, d/160: 7.5e-3 / 1.3e-3 -> 2.2e-3 / 3.6e-4; sphere,
  /// torus, ellipsoid unchanged. (Comparing the two fits' residuals instead picked degree 4 on
  /// the torus where degree 6 was 2.5x better.) So do P5 and P6 fits lowered below min_degree for
  /// want of points (a hole's wall three rows high in a 0.02 thick plate at h = 0.05: degree 3 over
  /// the plane, P6 2.4e-3, worse than linear 1.7e-3; refit: 7.1e-5, P4 3.1e-5), or lowered to
  /// min_degree itself (the safeguard, on the degree-6 stencil, over the plane: a cylinder on a
  /// 45 degree chamfer one triangle wide, P6 2.95e-3 -> 1.23e-4, P4 1.24e-4).
  double high_degree_condition = 1e-2;
  /// Two-sided wedges fitted at degree 4 (P2-P4), not exactly and at least elevated_feature_rings
  /// rings from a feature vertex (feature_ring_distance), are refitted at this degree (0: off) on
  /// its larger stencil; the refit is kept where its leave-one-out residual beats degree 4's on the
  /// same points and reference surface (elevate_fits, local_fit.cpp). Why: on
  /// free-form surfaces the fit, not the element, limits P4 (a squashed torus's tube top, radius of
  /// curvature 0.18 across it, at h = 0.1: nodes 1.2e-4 off the surface, Gmsh's exact-CAD P4 1.4e-5).
  /// Why leave-one-out: on a torus of long thin faces (400 x 12) degree 6 over four rings of 30
  /// degrees each put the nodes 1.4e-5 off where degree 4 had 2.4e-6. Why away from features: a
  /// stencil a feature cuts is lopsided, and degree 6 extrapolates (a loft below its rim, P4 2.1e-4
  /// -> 4.1e-4). Not on meshes whose median such wedge turns by at most exact.min_turn_deg: there
  /// degree 4 already fits to rounding (the 200k-triangle sphere: 3.1 -> 8.0 s for nothing), nor
  /// where the median of elevated_probes candidates spread over the mesh does not predict its
  /// points better by elevated_gain (leave-one-out residual over degree 4's). Measured medians:
  /// smooth surfaces 0.014-0.2 (bumpy sphere, torus.obj, squashed torus, loft), scans and remeshed
  /// scans 0.71-1.28 (noise sets their residuals: stanford_bunny_scan fits 3.07 -> 1.00 s, 2 threads).
  /// Figures: the git history of bench/README.md.
  int elevated_degree = 6;
  int elevated_feature_rings = 2;
  int elevated_probes = 256;
  double elevated_gain = 0.5;
  /// Surface fits have degree max(p, min_degree) for elements of order p (fit_degree()): the fit
  /// models the data, the order only says where the nodes go on it. Degree-4 stencils also reach
  /// reference_min_points. Measured (bench/accuracy.py, max error at h = 0.2 / 0.1 / 0.05, p at
  /// degree p -> at degree 4): P2 sphere 3.0 / 2.9 / 4.0x lower, torus 3.4 / 1.7 / 1.4x, ellipsoid
  /// 3.1 / 4.2 / 2.7x, capped cylinder 1.1 / 4.4 / 13x; P3 sphere 6.7 / 3.9 / 4.6x, torus 9.9 / 5.9 /
  /// 7.6x, ellipsoid 1.3 / 1.8 / 2.5x, cylinder 1.6 / 6.8 / 9.7x; CAD screw and T20 P2 1.0-1.6x
  /// lower, P3 within 1.25x but T20 d/20 2x higher. P2 and P3 then sit on the floor of nodes at
  /// their closest exact points (within 4% at h = 0.025). Odd degrees one above p did worse (P2 on
  /// degree 3: sphere 2x worse; P4 on degree 5: ellipsoid 2.5x better but T20 d/40 2x worse and the
  /// ellipsoid's order 4.5).
  int min_degree = 4;
  /// Degree reduction (WALF's safeguard): a degree-d block that changes by more than
  /// safeguard_tol (in units of h) and by >= 105 % of itself when the fit is truncated at
  /// degree d lowers the degree. Skipped when the stencil has >= safeguard_skip x #coefficients
  /// points (well-determined fits on fine meshes: the check only loses accuracy there).
  bool safeguard = true;
  double safeguard_tol = 0.05;
  double safeguard_skip = 2.0;
  double rank_tol = 1e-10;       ///< numerical rank: |R_kk| <= rank_tol * |R_00|
  double normal_cone = 0.1;      ///< drop stencil vertices seen only by faces with n_f . n <= this
  /// Support points (only in fits short of vertices): row weight support_weight x their
  /// Gaussian weight, lifted first onto the minimum-norm rank-truncated (at support_condition)
  /// degree-p fit of the vertices. Raw facet samples (support_lift = false) cap the error at
  /// O(h^2) (docs/algorithm.md, section 3); lifted ones cannot where the vertices determine the fit.
  double support_weight = 0.1;
  bool support_lift = true;
  /// A fit is short of vertices (and takes support points when they are enabled) when its
  /// degree had to be lowered or its pivot_ratio is below this.
  /// Measured: well-spread stencils have pivot_ratio >= 2e-4 even at p = 6, vertices on two
  /// lines (CAD strips) ~4e-6. Below it the fit also falls back to short_fit_degree.
  double support_condition = 1e-4;
  int short_fit_degree = 2;
  bool support_everywhere = false;  ///< testing: add support points to every fit, not only short ones
  /// Sanity bound (beyond WALF's safeguards): a fit that moves a point of its wedge's
  /// faces by more than max_offset x sqrt(2 x face area) is refitted one degree lower, down to
  /// the straight triangles. Catches extrapolating fits on CAD needles and thin parts.
  double max_offset = 0.5;
  /// ... and, on a face whose shortest edge is below needle_short_edge x its longest, at least
  /// max_offset x min_offset_edge x its longest edge. Such a needle, two corners nearly met
  /// (marching tetrahedra: 3e-6 wide, 0.14 long), is its long edge, along which an exact fit moves
  /// points by the edge's sagitta: at sqrt(2 area) alone every fit at its corners was lowered to
  /// the straight triangles. Not for every thin face: CAD exports' strips and caps need the bound
  /// (at needle_short_edge 0.05 ktoolcav's deviation went 0.84 -> 1.48%).
  double needle_short_edge = 0.01;
  double min_offset_edge = 0.25;
  /// Feature-curve fits (curve_fit.hpp) do not reach across a curve vertex whose two curve edges
  /// differ in length by more than this factor: the fits on either side are one-sided there.
  double curve_break_ratio = 3.0;
  /// Feature-curve fits measure offsets from the circle through the vertex that fits the curve's points
  /// best (CurveFit::kappa): exact on circular arcs however short.
  bool curve_reference_circle = true;
  /// ... where the curve's points lie within this x h of that circle (curve_fit.cpp).
  double circle_tolerance = 1e-3;
  /// Cone points (Features::vertex_cone) fit a cone model (apex_fit.hpp) to the vertices within
  /// apex_rings, kept where its RMS residual is below apex_max_residual x h (else the apex keeps
  /// its straight triangles), and given to the wedges within apex_share_rings. Why: no height
  /// function fits round an apex, and the rings next to it wrap round the axis within an edge
  /// or two. Measured P4 on Gmsh's cone (r = 0.5, height 1), h = 0.1 / 0.05 / 0.025: 3.7e-2 /
  /// 1.3e-2 / 8.0e-3 (the linear error: straight apex fans) -> 2.3e-3 / 8.2e-4 / 4.9e-4 (Gmsh's P4
  /// from the exact CAD: 9.7e-3 / 2.2e-3 / 2.0e-3); sharing 1 ring: 5.2e-3 / 1.3e-3 / 6.6e-4, 3
  /// rings: as 2.
  int apex_rings = 3;
  double apex_max_residual = 0.01;
  int apex_share_rings = 2;
  /// A wedge whose stencil's vertices lie on one quadric to rounding (wedge_exact_quadric: a CAD
  /// mesher's vertices on a plane, sphere, cylinder, cone, ellipsoid, or a torus: a cyclide) takes it as its
  /// fit. Why: on coarse meshes a height polynomial over a stencil that wraps a third of a
  /// cylinder round misses it by far more than the quadric, which is exact.
  bool exact_quadrics = true;
  ExactQuadricOptions exact;
};

/// The sanity bound of fits on a face with corners a, b, c: how far a fit may move a point of it
/// (FitOptions::max_offset, min_offset_edge).
double fit_offset_limit(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                        const FitOptions& opt);

/// Number of coefficients of the interpolatory basis u^j v^k, 1 <= j+k <= p.
inline int fit_coefficients(int p) { return (p + 1) * (p + 2) / 2 - 1; }

/// Degree of the surface and curve fits for elements of order p (FitOptions::min_degree).
inline int fit_degree(int p, const FitOptions& opt) { return p < 2 ? p : std::max(p, opt.min_degree); }

/// Degree of the surface fits at features (one-sided and band wedges) where the other fits have
/// degree d.
inline int feature_fit_degree(int d, const FitOptions& opt) { return std::min(d, std::max(opt.feature_max_degree, 1)); }

/// A height-function fit over the local frame (o; t1, t2, n). Coefficients c multiply the
/// monomials (u/h)^j (v/h)^k ordered by degree, then by descending j, and give height / h.
struct LocalFit {
  Eigen::Vector3d o = Eigen::Vector3d::Zero(), t1 = Eigen::Vector3d::UnitX(),
                  t2 = Eigen::Vector3d::UnitY(), n = Eigen::Vector3d::UnitZ();
  double h = 1.0;
  int requested_degree = 0;
  int degree = 0;               ///< degree actually fitted (0: the tangent plane)
  Eigen::VectorXd c;
  int points = 0;               ///< stencil vertices used (centre excluded)
  int support_points = 0;       ///< support points used
  int rings = 0;
  /// Smallest / largest pivot of the column-scaled QR of the accepted solve: near 0 when the
  /// points barely determine the polynomial (e.g. all on two lines).
  double pivot_ratio = 0;
  double residual = 0;          ///< norm of the weighted least-squares residual (units of h)
  bool identity = false;        ///< no sane fit: project() returns its argument (straight)
  /// Curvatures of the reference surface the heights are measured from, along t1 and t2
  /// (|k2| >= |k1|; both 0: the tangent plane): the torus touching the plane at o with those
  /// normal curvatures, axis along t2 through o + n / k1, tube radius 1 / |k2| (a cylinder when
  /// k1 == 0, a sphere when k1 == k2). A point's coordinates: arc length about the axis (u), then
  /// in the meridian plane arc length along the tube circle (v) and signed distance to it
  /// (height, positive along n). Arc lengths, not a projection on the plane: the chart is then
  /// built of sines and cosines, which add no singularity of their own. Why: a height function
  /// over the plane converges slowly where the stencil spans a large angle (its radius of
  /// convergence is about the curvature radius); measured from the osculating torus the
  /// residual is small and smooth (P4, torus h = 0.1: 1.05e-5 -> 3.5e-6).
  double k1 = 0, k2 = 0;
  /// Quadric reference (used instead of the torus when quadric_ref): the surface
  /// w = a u + b v + A u^2 + 2B uv + C v^2 + D u w + E v w + G w^2 in the frame (o; t1, t2, n),
  /// q = (a, b, A, B, C, D, E, G). A point's coordinates: (u, v) of its closest point on the
  /// quadric's sheet through o (that sheet is a graph over the plane there) and its signed
  /// distance along the quadric's normal (height), as in the torus chart.
  bool quadric_ref = false;
  double q[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  /// Height along n of the quadric's sheet through o above (u, v).
  double quadric_height(double u, double v) const;

  /// Height of the fitted surface at (u, v).
  double height(double u, double v) const;
  /// (u, v, height) of a point in the fit's frame (k2 == 0: plain projection on the plane).
  Eigen::Vector3d coords(const Eigen::Vector3d& q) const;
  /// The point at frame coordinates (u, v) and height z (the inverse of coords).
  Eigen::Vector3d point(double u, double v, double z) const;
  /// The fitted surface point above x (x moved along the reference's normal onto the fit).
  Eigen::Vector3d project(const Eigen::Vector3d& x) const;
  /// A cone point's model instead of a height function (apex_fit.hpp): o the apex, n the axis;
  /// heights z / h = (rho / h) g(phi) + (rho / h)^2 k(phi) at distance rho from the axis and
  /// azimuth phi from t1, g = c0 + c1 cos phi + c2 sin phi + c3 cos 2 phi + c4 sin 2 phi,
  /// k = c5 + c6 cos phi + c7 sin phi (c holds the first 3, 5 or 8).
  bool apex = false;
  /// Point of the apex model nearest x in x's meridian half-plane (apex_fit.cpp).
  Eigen::Vector3d apex_project(const Eigen::Vector3d& x) const;
  /// Point of the apex model at barycentric xi of the triangle with corners P (rows): the
  /// corners' distances from the axis and azimuths interpolated (a corner at the apex adds no
  /// azimuth), then the model's height there. Why not the projection of the straight point: the
  /// chord of a fan of three triangles passes near the axis, and its projected points crowd
  /// toward the ends of the arc (P4 elements there inverted).
  Eigen::Vector3d apex_point(const Eigen::Matrix3d& P, const Eigen::Vector3d& xi) const;
  /// The exact quadric through the wedge's stencil (exact_quadric.hpp, FitOptions::exact_quadrics):
  /// used instead of the height function when set; project() moves a point onto it. Shared, not
  /// held: most fits have none, and a fit is copied between passes.
  bool exact = false;
  std::shared_ptr<const ExactQuadric> surface;
  /// Where this fit puts the point at barycentric xi of the triangle with corners P, x being its
  /// position so far: apex_point for an apex model, else project(x).
  Eigen::Vector3d place(const Eigen::Matrix3d& P, const Eigen::Vector3d& xi, const Eigen::Vector3d& x) const {
    return apex ? apex_point(P, xi) : project(x);
  }
};

/// The reference surface of a fit (LocalFit::k1, k2 with their directions t1, t2 = n x t1).
struct FitReference {
  Eigen::Vector3d t1 = Eigen::Vector3d::Zero(), t2 = Eigen::Vector3d::Zero();
  double k1 = 0, k2 = 0;
  bool quadric_ref = false;  ///< LocalFit::quadric_ref (t1, t2 any tangent pair)
  double q[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  double residual = 0;       ///< weighted residual norm of its own least-squares fit (0: none)
};

/// Quadric reference through o for a fit along n (LocalFit::q): weighted least squares of the
/// points' heights; none (quadric_ref false) when the points do not determine it.
FitReference quadric_reference(const Eigen::Vector3d& o, const Eigen::Vector3d& n, const Eigen::MatrixXd& P,
                               const Eigen::VectorXd& w);

/// Reference surface for a fit at o along n to points P with weights w: the principal
/// curvatures and directions of the weighted least-squares quadratic through o (tilt terms
/// included, exact on a sphere), each limited to 0.9 / max |P_i - o| so that every point is
/// on the near side of the axis and of the tube centre, and 0 when negligible
/// (|k| max |P_i - o| < 1e-3). normal: set to n corrected by the fitted tilt; the reference's
/// t1, t2 are then tangent to it (else to n).
FitReference reference_surface(const Eigen::Vector3d& o, const Eigen::Vector3d& n, const Eigen::MatrixXd& P,
                               const Eigen::VectorXd& w, Eigen::Vector3d* normal = nullptr);

/// Orthonormal tangent pair for a unit normal.
void tangent_frame(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2);

/// The weighted least-squares system of a height fit as built (before column scaling): row i is
/// w_i times the monomials at point i's frame coordinates (u, v) / h, b_i w_i times its height / h.
/// Kept by a caller that will ask for the fit's leave-one-out residual: the rows' frame
/// coordinates (a Gauss-Newton projection per point over a quadric) are most of its cost.
struct FitDesign {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
};

/// Solves one interpolatory weighted least-squares fit at origin o with normal n, scale h,
/// to points P (#P x 3) with row weights w, lowering the degree when the system is short,
/// rank deficient or fails the safeguard. Q/ wq: extra (support) points and row weights.
/// basic: never lower the degree; minimum-norm solution of the system truncated at the
/// numerical rank (pivots below opt.support_condition). ref: the reference surface (default:
/// the tangent plane), e.g. from reference_surface. design (optional): receives the system's
/// rows, for leave_one_out_residual.
LocalFit solve_height_fit(const Eigen::Vector3d& o, const Eigen::Vector3d& n, double h,
                          const Eigen::MatrixXd& P, const Eigen::VectorXd& w, int degree,
                          const FitOptions& opt, const Eigen::MatrixXd& Q = Eigen::MatrixXd(),
                          const Eigen::VectorXd& wq = Eigen::VectorXd(), bool basic = false,
                          const FitReference& ref = FitReference(), FitDesign* design = nullptr);

/// Weighted leave-one-out residual (PRESS) of fit F over the points P (row weights w) it was
/// fitted to: sqrt(sum (r_i / (1 - h_ii))^2), h_ii the hat matrix diagonal, in units of h. How
/// well the fit predicts a point it did not see: the in-sample residual of a 14-coefficient fit
/// to 28 points flatters the more flexible reference. Infinity when a point alone fixes the fit.
/// lower_press (when lower_degree < F.degree): the same for the least-squares fit of
/// lower_degree in F's frame and reference, from the same factorization. design (optional): the
/// rows solve_height_fit built for F from the same P and w (no support points), not built again.
double leave_one_out_residual(const LocalFit& F, const Eigen::MatrixXd& P, const Eigen::VectorXd& w,
                              int lower_degree = 0, double* lower_press = nullptr,
                              const FitDesign* design = nullptr);

/// The fit of points P (row weights w) at o, area-weighted normal n0, over a reference surface:
/// the osculating torus (reference_surface), or the stencil's quadric where that fits much better
/// (FitOptions::reference_quadric), or the tangent plane when over the reference the fit would be
/// short or ill-posed. What fit_wedge does for stencils of >= reference_min_points around a vertex
/// off the features.
LocalFit reference_fit(const Eigen::Vector3d& o, const Eigen::Vector3d& n0, double h, const Eigen::MatrixXd& P,
                       const Eigen::VectorXd& w, int p, const FitOptions& opt);

/// Largest angle in degrees between a face normal of wedge w and n.
double wedge_turn_deg(const Mesh& mesh, const Wedges& W, int w, const Eigen::Vector3d& n);

/// Result of fitting every wedge.
struct FitResult {
  std::vector<LocalFit> fits;             ///< per wedge
  std::vector<long long> degree_histogram;  ///< [d] = number of fits of final degree d
  long long downgraded = 0;               ///< fits below the requested degree
  long long with_support = 0;             ///< fits that used support points
  long long agreeing_fits = 0;            ///< one-sided wedges given a quadric or torus fit by one_sided_quadric_agreement
  long long exact_fits = 0;               ///< wedges on an exact quadric or plane (FitOptions::exact_quadrics)
  long long shared_exact_fits = 0;        ///< ... of which taken from a neighbour (share_exact_fits)
  long long refitted_surfaces = 0;        ///< shared exact surfaces refitted to all their wedges' corners
  long long apex_fits = 0;                ///< wedges on a cone point's model: its own and its neighbours' (share_apex_fits)
  long long elevated_fits = 0;            ///< wedges refitted at FitOptions::elevated_degree
  double mean_points = 0;
  double seconds = 0;
};

/// Per vertex, the number of edges to the nearest feature vertex (one with several wedges, or on
/// an open or non-manifold edge): 0 on features; INT_MAX where none is connected.
std::vector<int> feature_ring_distance(const Topology& T, const Wedges& W);

/// Fits every wedge of W at degree p (TBB-parallel, deterministic), some at
/// FitOptions::elevated_degree when p is 4. support may be null.
FitResult fit_wedges(const Mesh& mesh, const Topology& T, const Wedges& W, int p,
                     const SupportPoints* support, const FitOptions& opt = {});

/// Reusable working memory of fit_wedge: fit_wedges keeps one per thread. Results never
/// depend on it; the overloads without it build a fresh one.
struct FitScratch {
  StencilScratch stencil;
  StampSet seen;             ///< stencil vertices inside the normal cone
  std::vector<int> pts;
  std::vector<double> sorted;
  /// Set (never cleared) when a one-sided quadric fit was refused by a gate the agreement pass
  /// opens (one_sided_quadric_gap, or the stencil at max_rings): only those wedges are refit.
  bool quadric_gate_refused = false;
  /// One-sided wedges fit over their stencil's torus or quadric (reference_fit) instead of the
  /// plane: the agreement pass's candidate (FitOptions::one_sided_torus).
  bool one_sided_torus = false;
  /// Set by the caller (FitOptions::elevated_degree): the fit also solves degree 4 on its own
  /// points and reference surface and records in loo_ratio its leave-one-out residual over that
  /// one's (left alone when the fit is not of the degree asked).
  bool compare_with_degree_4 = false;
  double loo_ratio = 0;
  /// Per wedge (set by fit_wedges, may be null): bit 1 once wedge_exact_quadric found no surface
  /// for it, bit 2 once wedge_plane found none. Both depend on the wedge alone, so its refits
  /// (lower degrees, the agreement pass) skip them.
  std::vector<char>* no_exact_surface = nullptr;
};

/// The same without the sanity bound (used by fit_wedge).
LocalFit fit_wedge_unchecked(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                             const SupportPoints* support, const std::vector<int>& support_start,
                             const std::vector<int>& support_index, const FitOptions& opt);

/// Fits one wedge (what fit_wedges does per item). support_by_face: CSR of support point
/// indices per face (may be empty).
LocalFit fit_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                   const SupportPoints* support, const std::vector<int>& support_start,
                   const std::vector<int>& support_index, const FitOptions& opt);

/// fit_wedge and fit_wedge_unchecked with caller-provided working memory (same results).
LocalFit fit_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                   const SupportPoints* support, const std::vector<int>& support_start,
                   const std::vector<int>& support_index, const FitOptions& opt, FitScratch& scratch);
LocalFit fit_wedge_unchecked(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                             const SupportPoints* support, const std::vector<int>& support_start,
                             const std::vector<int>& support_index, const FitOptions& opt,
                             FitScratch& scratch);

}  // namespace hocurve
