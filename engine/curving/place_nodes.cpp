#include "engine/curving/place_nodes.hpp"

#include "engine/core/stopwatch.hpp"
#include "engine/curving/share_exact_fits.hpp"
#include "engine/highorder/validity.hpp"

#include <Eigen/Geometry>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>

namespace hocurve {

Eigen::Vector3d blend_point(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits,
                            int f, const Eigen::Vector3d& xi, const LocalFit* face_fit) {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) x += xi[j] * mesh.V.row(mesh.F(f, j)).transpose();
  return blend_projection(mesh, W, fits, f, xi, x, face_fit);
}

Eigen::Vector3d blend_projection(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits, int f,
                                 const Eigen::Vector3d& xi, const Eigen::Vector3d& x, const LocalFit* face_fit) {
  if (face_fit) return face_fit->project(x);
  Eigen::Matrix3d P;
  for (int i = 0; i < 3; ++i) P.row(i) = mesh.V.row(mesh.F(f, i));
  const LocalFit* fit[3];
  for (int j = 0; j < 3; ++j) fit[j] = &fits[W.corner_wedge(f, j)];
  // A corner off every exact quadric (its stencil spans two CAD faces: a tangent junction) takes
  // the exact quadric of another corner that passes through it and along the face: the face lies
  // on that CAD face. For an edge, the corner off it (weight 0) may offer it too. Not a cone
  // model's corner: it places a face's points by their azimuth (LocalFit::apex_point), where
  // projections of a wide fan's chords crowd (Gmsh's cone at h = 0.05: P6 8.3e-4 -> 2.6e-3).
  const Eigen::Vector3d normal = face_normal(mesh, f).normalized();
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3 && !fit[j]->exact && !fit[j]->apex; ++k) {
      const LocalFit& other = fits[W.corner_wedge(f, k)];
      if (k != j && other.exact && other.surface->contains(P.row(j)) &&
          std::abs(normal.dot(other.surface->gradient(P.row(j)).normalized())) >= 0.5)
        fit[j] = &other;
    }
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j)
    if (xi[j] != 0.0) out += xi[j] * fit[j]->place(P, xi, x);
  return out;
}

Eigen::Vector3d edge_barycentric(const Mesh& mesh, const Topology& T, int e, int f, double t) {
  Eigen::Vector3d xi = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) {
    if (mesh.F(f, j) == T.E(e, 0)) xi[j] = 1 - t;
    if (mesh.F(f, j) == T.E(e, 1)) xi[j] = t;
  }
  return xi;
}

namespace {
/// Edge e's two faces lie on one exact surface: each face's exact surface (face_fit) holds the
/// other face too (face_on). Then e is a chord of it, though the features took it for a crease:
/// the kink test's false creases where a coarse cylinder meets a torus at a tangent junction
/// (the elbow at Gmsh's size: a curve fit 3.4e-2 off the cylinder).
bool chord_of_one_surface(const Mesh& mesh, const Topology& T, const std::vector<const LocalFit*>& face_fit, int e) {
  if (T.edge_faces[e].size() != 2) return false;
  const int f = T.edge_faces[e][0], g = T.edge_faces[e][1];
  const LocalFit *A = face_fit[f], *B = face_fit[g];
  if (!A || !B || !A->surface || !B->surface) return false;
  const ExactQuadricOptions opt;
  double side_a = 0, side_b = 0;
  return face_on(mesh, f, *A->surface, opt, side_a) && face_on(mesh, g, *A->surface, opt, side_a) &&
         face_on(mesh, g, *B->surface, opt, side_b) && face_on(mesh, f, *B->surface, opt, side_b);
}

/// Feature edge points at the parameters the placement asks for again and again (edge nodes,
/// curve_sides_within's quarters, face nodes' side points), each computed once per curve edge:
/// a curve edge's crossing was searched 15-21 times, by two faces and for its own nodes.
struct EdgePointMemo {
  std::vector<double> ts;    ///< the parameters, sorted
  std::vector<int> slot;     ///< per edge: its first row in points, or -1
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> points;  ///< row slot[e] + i: the point at ts[i]
  const double* find(int e, double t) const {
    if (slot.empty() || slot[e] < 0) return nullptr;
    const auto it = std::lower_bound(ts.begin(), ts.end(), t);
    if (it == ts.end() || *it != t) return nullptr;
    return &points(slot[e] + (it - ts.begin()), 0);
  }
};

/// What a feature edge's placement may consult besides the fits (any may be null).
struct EdgeContext {
  const LongEdgeResult* long_edge = nullptr;
  const std::vector<int>* planar = nullptr;
  const Features* feat = nullptr;
  const EdgePointMemo* memo = nullptr;
  /// Per edge, 1 where it is placed on its faces' exact surfaces' crossing (with face_fit, the
  /// faces' exact surfaces): such an edge is a curve side of its faces too.
  const std::vector<char>* crossing = nullptr;
  const std::vector<const LocalFit*>* face_fit = nullptr;
};

/// Feature edges at vertex v.
int feature_valence(const Topology& T, const Features& feat, int v) {
  int n = 0;
  for (auto [b, e] = T.edges_of(v); b != e; ++b) n += feat.edge_feature[*b] != 0;
  return n;
}

/// Alternating projections x <- project(x), each step kept in the plane normal to unit u through
/// `anchor`, from `start` until a step is at most tol; start itself where they do not converge
/// within max_steps (converged, where given, tells which).
template <class Project>
Eigen::Vector3d alternate(const Project& project, const Eigen::Vector3d& start, const Eigen::Vector3d& anchor,
                          const Eigen::Vector3d& u, double tol, int max_steps, bool* converged = nullptr) {
  if (converged) *converged = false;
  Eigen::Vector3d x = start;
  constexpr int window = 5;
  std::array<double, window + 1> steps{};
  for (int it = 0; it < max_steps; ++it) {
    Eigen::Vector3d y = project(x);
    y -= (y - anchor).dot(u) * u;
    const double step = (y - x).norm();
    x = y;
    if (step <= tol) {
      if (converged) *converged = true;
      return x;
    }
    if (!std::isfinite(step)) return start;
    // Hopeless: at the rate of the last `window` steps the tolerance lies well past the budget
    // (surfaces crossing at a small angle, as noisy scans' fits: 30% of boot's searches ran all
    // 100 steps and returned start, 57% of all the steps taken).
    steps[it % (window + 1)] = step;
    if (it >= 2 * window) {
      const double rate = std::pow(step / steps[(it - window) % (window + 1)], 1.0 / window);
      if (!(rate < 1) || it + std::log(tol / step) / std::log(rate) > 1.5 * max_steps) return start;
    }
  }
  return start;
}

/// Where the surface fits of interior edge e's two sides cross the plane normal to its chord
/// through `anchor`: alternating projections from `start`, at most max_steps (start itself where
/// they do not converge).
Eigen::Vector3d surface_crossing(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits,
                                 int e, double t, const Eigen::Vector3d& start, const Eigen::Vector3d& anchor,
                                 int max_steps = 100) {
  const int f1 = T.edge_faces[e][0], f2 = T.edge_faces[e][1];
  const Eigen::Vector3d xi1 = edge_barycentric(mesh, T, e, f1, t), xi2 = edge_barycentric(mesh, T, e, f2, t);
  const Eigen::Vector3d chord = mesh.V.row(T.E(e, 1)) - mesh.V.row(T.E(e, 0));
  const double len = chord.norm();
  auto project = [&](const Eigen::Vector3d& x) {
    return blend_projection(mesh, W, fits, f2, xi2, blend_projection(mesh, W, fits, f1, xi1, x));
  };
  return alternate(project, start, anchor, chord / len, 1e-13 * len, max_steps);
}

/// Where along its chord (0..1) a circular arc's point closest to the chord's point at t lies
/// (the arc's centre, that point and it in line), the arc rising `rise` x half the chord above
/// its middle: where a projection onto a cylinder or sphere through the arc puts it.
double arc_chord_fraction(double rise, double t) {
  if (!(rise > 1e-12)) return t;
  const double radius = (1 + rise * rise) / (2 * rise), x = 2 * t - 1;  // in half chords
  const double d = std::hypot(x, radius - rise);
  return d > 0 ? 0.5 * (1 + radius * x / d) : t;
}

/// Point at t of edge e, off the feature curves, whose two faces lie on exact surfaces A and B
/// (face_exact_fits) that cross at its middle at min_cross_deg or more: where they cross, as a
/// feature edge between exact sides (feature_edge_point), the plane through the arc's point
/// nearest the chord's (arc_chord_fraction). Why: a sphere meeting a plane at 33.6 degrees,
/// below angle_deg, where the kink test missed a rim's end edges (their stencils spoilt by a
/// block's corner): placed on the plane's fit, such an edge stayed the plane's chord, 7.5e-3 inside
/// the sphere (curvature-sized dome, P4 1.6e-3). Null where the surfaces are one, or tangent (a
/// fillet's junction: no crossing to find), or the crossing is not found within a quarter of
/// the edge's length of its chord.
std::optional<Eigen::Vector3d> exact_crossing_point(const Mesh& mesh, const Topology& T, int e, const LocalFit& A,
                                                    const LocalFit& B, double t) {
  constexpr double min_cross_deg = 15;  // at 15 degrees alternating projections gain 0.93 a step
  constexpr int max_steps = 400;
  if (!A.exact || !B.exact || !A.surface || !B.surface) return std::nullopt;
  const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)).transpose(), b = mesh.V.row(T.E(e, 1)).transpose();
  const double len = (b - a).norm();
  const Eigen::Vector3d u = (b - a) / len, middle = 0.5 * (a + b);
  const Eigen::Vector3d na = A.surface->gradient(middle).normalized(), nb = B.surface->gradient(middle).normalized();
  if (!(std::abs(na.dot(nb)) <= std::cos(min_cross_deg * std::numbers::pi / 180))) return std::nullopt;
  auto project = [&](const Eigen::Vector3d& x) { return B.project(A.project(x)); };
  bool converged = false;
  const Eigen::Vector3d mid = alternate(project, middle, middle, u, 1e-13 * len, max_steps, &converged);
  if (!converged) return std::nullopt;
  const double s = arc_chord_fraction((mid - middle).norm() / (0.5 * len), t);
  const Eigen::Vector3d line = (1 - s) * a + s * b;
  const Eigen::Vector3d x = alternate(project, line, line, u, 1e-13 * len, max_steps, &converged);
  if (!converged || !((x - line).norm() <= 0.25 * len)) return std::nullopt;
  return x;
}

/// True when both ends of edge e have exact quadric fits on both its sides (LocalFit::exact): two
/// CAD faces known to rounding, whose crossing is the curve itself.
bool exact_sides(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits, int e) {
  for (int f : T.edge_faces[e])
    for (int j = 0; j < 3; ++j)
      if ((mesh.F(f, j) == T.E(e, 0) || mesh.F(f, j) == T.E(e, 1)) && !fits[W.corner_wedge(f, j)].exact) return false;
  return true;
}

/// Point at t of feature edge e (or of an edge on its faces' exact surfaces' crossing, ctx.crossing:
/// exact_crossing_point): where the surface fits of its two sides cross the plane normal
/// to the chord at t, found by alternating projections from the curve fit's point (linear
/// convergence, at cos^2 of the crease angle, >= 35 degrees: 0.67 per step). Why: a curve fit
/// follows its chain of vertices, but where two surfaces cross in a curve that turns away from
/// any circle (a cylinder crossed by a hole) its nodes missed the crossing by 6x Gmsh's exact-CAD
/// P4 error, while each side's surface fit is within the P4 error there (cross hole h = 0.1, P4
/// 2.1e-5 -> 6.5e-7; Gmsh's CAD P4 3.7e-6). And a curve that is this one edge between two corners
/// has fits of its two ends only: a line, whatever the surfaces do (the screw's slot floor meets
/// its conical head in an arc one edge long, left a chord 2.1e-2 off at d/40).
/// Between exact sides the plane goes through the point closest to the chord's point at t of the
/// arc through the edge's ends and the crossing at its middle, not through the curve fit's point:
/// a fit through a coarse crossing that turns out of any plane drifts along the chord, and the
/// nodes, exact on the crossing, bunched (cross hole at Gmsh's sizes once its 16 false corners were
/// gone, features.hpp coarse_circle_max_deg: P4 3.78e-5 -> 5.89e-4). Through the chord's point
/// itself, the nodes along a circular rim are spaced unlike the faces' beside it, projected onto
/// their surfaces (a plate's hole walls: P6 1.4e-10 -> 7.5e-8).
/// The curve point stays:
/// - where an end fit found its points on a circle (CurveFit::on_circle): exact, while the
///   surface fits of a thin plate's walls are not (a stadium's arcs moved 4.8e-4 off their circle);
/// - on long edges (long_edge->edge): CAD exports' fits do not reach along them (t13's 48 mm
///   walls moved by 3.5 mm);
/// - between two flat patches, whose fits the curves beside them may bend (a stadium's straight
///   side between its end arcs: 2.2e-3);
/// - on a one-edge curve unless both corners join three curves or more (a CAD face's corner, not a
///   scan's noise crease turning);
/// - where the projections do not converge or move it further than 0.1% of the edge length from a
///   fitted curve (with 1%, T20 at d/20 went 4.4e-3 -> 8.7e-3: coarse fits cross off the curve;
///   shared meshes unchanged either way), 5% from a one-edge chord (an arc of 23 degrees per
///   edge: with a quarter, scans' elements invalid before repair tripled).
Eigen::Vector3d feature_edge_point(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits,
                                   const CurveFitResult& curves, const EdgeContext& ctx, int e, double t) {
  if (ctx.memo)
    if (const double* x = ctx.memo->find(e, t)) return Eigen::Vector3d(x[0], x[1], x[2]);
  if (ctx.crossing && (*ctx.crossing)[e]) {
    const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)).transpose(), b = mesh.V.row(T.E(e, 1)).transpose();
    const std::optional<Eigen::Vector3d> x =
        exact_crossing_point(mesh, T, e, *(*ctx.face_fit)[T.edge_faces[e][0]], *(*ctx.face_fit)[T.edge_faces[e][1]], t);
    return x ? *x : Eigen::Vector3d((1 - t) * a + t * b);
  }
  const Eigen::Vector3d line = curve_edge_point(mesh, T, curves, e, t);
  const CurveFit &c0 = curves.at(e, 0), &c1 = curves.at(e, 1);
  const bool fitted = c0.points > 2 || c1.points > 2;
  if (T.edge_faces[e].size() == 2 && exact_sides(mesh, T, W, fits, e)) {
    // Each step gains cos^2 of the angle between the surfaces: two spheres meeting at 29 degrees (a
    // concave crease turning by 151) need 115 steps; with 100 the quarter nodes of such an edge
    // stayed on its curve fit, 7.9e-4 off (a block's corner under two spherical caps, h = 0.1).
    constexpr int exact_steps = 400;
    const Eigen::Vector3d a = mesh.V.row(T.E(e, 0)).transpose(), b = mesh.V.row(T.E(e, 1)).transpose();
    const Eigen::Vector3d mid = surface_crossing(mesh, T, W, fits, e, 0.5, curve_edge_point(mesh, T, curves, e, 0.5),
                                                 0.5 * (a + b), exact_steps);
    const double s = arc_chord_fraction((mid - 0.5 * (a + b)).norm() / (0.5 * (b - a).norm()), t);
    const Eigen::Vector3d x = surface_crossing(mesh, T, W, fits, e, t, line, (1 - s) * a + s * b, exact_steps);
    return (x - line).norm() <= 0.25 * (b - a).norm() ? x : line;
  }
  if (T.edge_faces[e].size() != 2 || (fitted && (c0.on_circle || c1.on_circle)) ||
      (ctx.long_edge && !ctx.long_edge->edge.empty() && ctx.long_edge->edge[e]))
    return line;
  const int f1 = T.edge_faces[e][0], f2 = T.edge_faces[e][1];
  if (ctx.planar && (*ctx.planar)[f1] >= 0 && (*ctx.planar)[f2] >= 0) return line;  // plane meets plane
  if (!fitted && ctx.feat &&
      (feature_valence(T, *ctx.feat, T.E(e, 0)) < 3 || feature_valence(T, *ctx.feat, T.E(e, 1)) < 3))
    return line;
  const Eigen::Vector3d x = surface_crossing(mesh, T, W, fits, e, t, line, line);
  const double len = (mesh.V.row(T.E(e, 1)) - mesh.V.row(T.E(e, 0))).norm();
  return (x - line).norm() <= (fitted ? 1e-3 : 0.05) * len ? x : line;
}

/// What the curve fit moves feature edge e's point at t beyond face f's surface blend there (its
/// exact surface's point, where given), within f's plane (unit normal n).
Eigen::Vector3d curve_side_shift(const Mesh& mesh, const Topology& T, const Wedges& W,
                                 const std::vector<LocalFit>& fits, const CurveFitResult& curves,
                                 const EdgeContext& ctx, int e, int f, const Eigen::Vector3d& n, double t,
                                 const LocalFit* surface) {
  const Eigen::Vector3d d = feature_edge_point(mesh, T, W, fits, curves, ctx, e, t) -
                            blend_point(mesh, W, fits, f, edge_barycentric(mesh, T, e, f, t), surface);
  return d - d.dot(n) * n;
}

/// How a face's nodes follow its curve sides.
struct CurveSideBlend {
  double power = 1;                  ///< weight of a side's shift: (1 - xi of the opposite corner)^power
  std::array<bool, 3> follow{};      ///< per side j (corners j, j + 1): its shift counts
};

/// The curve sides of face f whose shift (at a quarter, half and three quarters of the side) stays
/// within max_shift x the side's length, those whose points there lie on the face's exact surface
/// (surface, may be null), and those whose two sides have exact fits (exact_sides): the
/// limit keeps scans' noisy curve fits out of the faces, while there the curve is the crossing of two
/// exact surfaces, or a CAD curve's fit (two cylinders crossed at h = 0.1: shifts of 7.6% of the side,
/// P4 8.6e-5 -> 2.3e-6).
std::array<bool, 3> curve_sides_within(const Mesh& mesh, const Topology& T, const Wedges& W,
                                       const std::vector<LocalFit>& fits, const CurveFitResult& curves,
                                       const EdgeContext& ctx, const std::vector<char>& on_curve, int f,
                                       double max_shift, const LocalFit* surface) {
  const Eigen::Vector3d n = face_normal(mesh, f).normalized();
  std::array<bool, 3> within{};
  for (int j = 0; j < 3; ++j) {
    const int e = T.FE(f, j);
    if (!on_curve[e]) continue;
    if (T.edge_faces[e].size() == 2 && exact_sides(mesh, T, W, fits, e)) {
      within[j] = true;
      continue;
    }
    double largest = 0;
    bool on_surface = surface && surface->surface;
    for (double t : {0.25, 0.5, 0.75}) {
      largest = std::max(largest, curve_side_shift(mesh, T, W, fits, curves, ctx, e, f, n, t, surface).norm());
      on_surface = on_surface && surface->surface->contains(feature_edge_point(mesh, T, W, fits, curves, ctx, e, t));
    }
    within[j] = on_surface || largest <= max_shift * (mesh.V.row(T.E(e, 0)) - mesh.V.row(T.E(e, 1))).norm();
  }
  return within;
}

/// Face point of a face with sides on feature curves: the surface blend plus, from each such side,
/// what the curve fit moves that side's point beyond the blend (at the point's projection from the
/// opposite corner), weighted by (1 - xi of that corner)^power, projected back onto the corner fits.
/// Why: a curve side moves along the curve's own normal (a rim circle's radius), the blend along
/// the fits' normals; where the surface meets the curve's plane obliquely (a cone under a flat top,
/// a sphere cut by a plane, two cylinders crossing) the two differ tangentially by up to the chord's
/// sagitta. Face nodes left on the blend crowd against the side (T20 d/20 P6: min J / J_straight
/// -0.94) or, where still valid, bend the element between its nodes: P4 converged at order 3 along
/// every such curve. Power 1 spreads the shift as a cone from the opposite corner (not smooth
/// there); power 3 vanishes to third order at that corner and stays within the P4 polynomials
/// (measured with bench/cad_sweep.py). surface (may be null): the face's exact surface, which then
/// takes the place of the blend.
Eigen::Vector3d curve_side_face_point(const Mesh& mesh, const Topology& T, const Wedges& W,
                                      const std::vector<LocalFit>& fits, const CurveFitResult& curves,
                                      const EdgeContext& ctx, int f, const Eigen::Vector3d& xi,
                                      const CurveSideBlend& blend, const LocalFit* surface) {
  Eigen::Vector3d x = blend_point(mesh, W, fits, f, xi, surface);
  const Eigen::Vector3d n = face_normal(mesh, f).normalized();
  for (int j = 0; j < 3; ++j) {
    const int e = T.FE(f, j);  // joins corners j and (j + 1) % 3; the opposite corner is (j + 2) % 3
    const double side = 1 - xi[(j + 2) % 3];
    if (!blend.follow[j] || !(side > 0)) continue;
    const int a = T.E(e, 0) == mesh.F(f, j) ? j : (j + 1) % 3;  // corner at the edge's start
    const double t = xi[(a == j) ? (j + 1) % 3 : j] / side;   // from E(e, 0) to E(e, 1)
    x += std::pow(side, blend.power) * curve_side_shift(mesh, T, W, fits, curves, ctx, e, f, n, t, surface);
  }
  return blend_projection(mesh, W, fits, f, xi, x, surface);
}
/// feature_edge_point of every curve edge (on_curve) at the parameters placement asks for: its
/// nodes (line), curve_sides_within's quarters, and its faces' nodes' side points (tri's face
/// nodes; curve_side_face_point's t, the side either way round).
EdgePointMemo memo_edge_points(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits,
                               const CurveFitResult& curves, const EdgeContext& direct,
                               const std::vector<char>& on_curve, const Eigen::VectorXd& line,
                               const Eigen::MatrixXd& tri) {
  EdgePointMemo memo;
  const int p = static_cast<int>(line.size()) - 1, ne = T.num_edges();
  memo.ts = {0.25, 0.5, 0.75};
  for (int k = 1; k < p; ++k) memo.ts.push_back(line[k]);
  for (Eigen::Index k = 3 * p; k < tri.rows(); ++k) {
    const double u = tri(k, 0), v = tri(k, 1);
    const Eigen::Vector3d xi(1 - u - v, u, v);
    for (int j = 0; j < 3; ++j) {
      const double side = 1 - xi[(j + 2) % 3];
      if (side > 0) memo.ts.insert(memo.ts.end(), {xi[(j + 1) % 3] / side, xi[j] / side});
    }
  }
  std::sort(memo.ts.begin(), memo.ts.end());
  memo.ts.erase(std::unique(memo.ts.begin(), memo.ts.end()), memo.ts.end());
  const int nt = static_cast<int>(memo.ts.size());
  memo.slot.assign(ne, -1);
  int rows = 0;
  for (int e = 0; e < ne; ++e)
    if (on_curve[e]) memo.slot[e] = rows, rows += nt;
  memo.points.resize(rows, 3);
  tbb::parallel_for(tbb::blocked_range<int>(0, ne), [&](const tbb::blocked_range<int>& r) {
    for (int e = r.begin(); e < r.end(); ++e)
      for (int i = 0; on_curve[e] && i < nt; ++i)
        memo.points.row(memo.slot[e] + i) = feature_edge_point(mesh, T, W, fits, curves, direct, e, memo.ts[i]).transpose();
  });
  return memo;
}
}  // namespace

PlacementResult place_nodes(const Mesh& mesh, const Topology& T, const Wedges& W,
                            const std::vector<LocalFit>& fits, const Features* feat,
                            const CurveFitResult* curves, int p, NodeDistribution d,
                            const LongEdgeResult* long_edge, const std::vector<int>* planar,
                            const std::vector<const LocalFit*>* face_fits) {
  const auto t0 = Clock::now();
  PlacementResult R;
  R.mesh = high_order_frame(mesh, T, p, d);
  HighOrderMesh& hm = R.mesh;
  const int ne = T.num_edges(), nf = mesh.num_faces();
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  if (p <= 1) return R;
  const Eigen::VectorXd line = line_reference_nodes(p, d);
  const Eigen::MatrixXd tri = triangle_reference_nodes(p, d);

  // Faces on a neighbour's exact surface (face_exact_fits), and the edges they place.
  std::vector<const LocalFit*> face_fit(nf, nullptr);
  if (face_fits) face_fit = *face_fits;
  std::vector<char> on_curve(ne, 0);
  if (feat && curves)
    for (int e = 0; e < ne; ++e)
      on_curve[e] = !feat->edge_feature.empty() && feat->edge_feature[e] && curves->fitted_edge(e) &&
                    !chord_of_one_surface(mesh, T, face_fit, e);
  const EdgeContext direct{long_edge, planar, feat};
  const EdgePointMemo memo =
      curves ? memo_edge_points(mesh, T, W, fits, *curves, direct, on_curve, line, tri) : EdgePointMemo{};
  EdgeContext ctx = direct;
  ctx.memo = &memo;
  std::vector<char> edge_on_face_fit(ne, 0);
  R.crossing.assign(ne, 0);
  auto place_edge = [&](int e, bool blend_only) {
    const int a = T.E(e, 0);
    const int f = T.edge_faces[e].empty() ? -1 : T.edge_faces[e][0];
    // The face whose surface places the edge's nodes (once per edge: conforming).
    const int g = !blend_only && f >= 0 && !face_fit[f] && T.edge_faces[e].size() == 2 && face_fit[T.edge_faces[e][1]]
                      ? T.edge_faces[e][1]
                      : f;
    const LocalFit* surface = blend_only || g < 0 ? nullptr : face_fit[g];
    // An unreached long edge goes on the PN curve of its first face (a long face, as all its
    // faces are; computed once per edge: conforming).
    const bool pn = long_edge && long_edge->unreached[e];
    edge_on_face_fit[e] = !on_curve[e] && f >= 0 && !pn && surface;
    // Both faces on exact surfaces: the edge may be where they cross (exact_crossing_point).
    const bool crosses = !blend_only && edge_on_face_fit[e] && T.edge_faces[e].size() == 2 &&
                         face_fit[T.edge_faces[e][0]] && face_fit[T.edge_faces[e][1]];
    R.crossing[e] = 0;
    for (int k = 1; k < p; ++k) {
      const double t = line[k];
      Eigen::Vector3d q;
      if (on_curve[e] || f < 0) {
        q = curves ? feature_edge_point(mesh, T, W, fits, *curves, ctx, e, t)
                   : Eigen::Vector3d((1 - t) * mesh.V.row(a) + t * mesh.V.row(T.E(e, 1)));
      } else {
        const std::optional<Eigen::Vector3d> crossing =
            crosses ? exact_crossing_point(mesh, T, e, *surface, *face_fit[T.edge_faces[e][0] == g ? T.edge_faces[e][1] : T.edge_faces[e][0]], t)
                    : std::nullopt;
        if (crossing) R.crossing[e] = 1;
        q = crossing ? *crossing
            : pn     ? long_face_point(mesh, W, f, edge_barycentric(mesh, T, e, f, t), long_edge->options)
                     : blend_point(mesh, W, fits, g, edge_barycentric(mesh, T, e, g, t), surface);
      }
      hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1) = q.transpose();
    }
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, ne), [&](const tbb::blocked_range<int>& r) {
    for (int e = r.begin(); e < r.end(); ++e) place_edge(e, false);
  });
  const JacobianBasis basis(p);
  ValidityOptions floor;  // the repair's default quality floor (not --min-jacobian): below it the face would be pulled
  floor.min_scaled_jacobian = floor.quality_floor;
  auto place_face = [&](int f) {
    for (int k = 0; k < npf; ++k) {
      const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
      hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k) =
          blend_point(mesh, W, fits, f, Eigen::Vector3d(1 - u - v, u, v), face_fit[f]).transpose();
    }
  };
  // Curve sides of the faces: feature curves, and edges placed where two exact surfaces cross.
  std::vector<char> side_curve = on_curve;
  for (int e = 0; e < ne; ++e) side_curve[e] = side_curve[e] || R.crossing[e];
  ctx.crossing = &R.crossing;
  ctx.face_fit = &face_fit;
  if (npf > 0) {
    tbb::parallel_for(tbb::blocked_range<int>(0, nf), [&](const tbb::blocked_range<int>& r) {
      for (int f = r.begin(); f < r.end(); ++f) {
        const bool pn = long_edge && long_edge->face[f];
        Eigen::Matrix3d P, N;
        if (pn) {
          for (int j = 0; j < 3; ++j) P.row(j) = mesh.V.row(mesh.F(f, j));
          N = same_size_normals(mesh, W, f, long_edge->options);
        }
        if (pn)
          for (int k = 0; k < npf; ++k) {
            const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
            hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k) =
                pn_triangle_point(P, N, Eigen::Vector3d(1 - u - v, u, v)).transpose();
          }
        else
          place_face(f);
        bool curve_side = false;
        for (int j = 0; j < 3; ++j) curve_side = curve_side || side_curve[T.FE(f, j)];
        if (pn || !curve_side) continue;
        // A valid face follows its curve sides smoothly (power 3), those shifted by at most 5% of
        // their length (on scans curve and surface fits disagree by noise: spot, up to 14% of h,
        // deviation from the input 0.31 -> 0.36% without the limit) or on its exact surface, unless
        // that takes it below the floor. A face on a neighbour's exact surface does so on it: left
        // there, a sphere's coarse faces beside its rim bent between their nodes (curvature-sized
        // dome P4 1.1e-4 -> 6.9e-6, Gmsh's exact-CAD P4 2.6e-5). A face the plain blend leaves below the floor takes every curve side, smoothly if
        // that lifts it above the floor, else with power 1 (the spread that frees crowded nodes) if
        // that raises its min J. Why smoothly first: at Gmsh's sizes a tee's saddle curve shifts its
        // sides by up to 17% of their length, and power 1 left its faces valid but bent (P4 2.7e-4;
        // 6.2e-5 with power 3; the cross hole 3.0e-4 -> 3.8e-5).
        const ElementValidity plain = check_element(basis, element_nodes(hm, f), floor);
        const std::array<bool, 3> all_sides{side_curve[T.FE(f, 0)] != 0, side_curve[T.FE(f, 1)] != 0,
                                            side_curve[T.FE(f, 2)] != 0};
        const CurveSideBlend smooth{
            3, plain.valid ? curve_sides_within(mesh, T, W, fits, *curves, ctx, side_curve, f, 0.05, face_fit[f]) : all_sides};
        if (!smooth.follow[0] && !smooth.follow[1] && !smooth.follow[2]) continue;
        const Eigen::MatrixXd kept = hm.face_nodes.middleRows(static_cast<Eigen::Index>(f) * npf, npf);
        auto follow = [&](const CurveSideBlend& blend) {
          for (int k = 0; k < npf; ++k) {
            const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
            hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k) =
                curve_side_face_point(mesh, T, W, fits, *curves, ctx, f, Eigen::Vector3d(1 - u - v, u, v), blend,
                                      face_fit[f])
                    .transpose();
          }
          return check_element(basis, element_nodes(hm, f), floor).min_scaled_jacobian;
        };
        const double corrected = follow(smooth);
        if (corrected > floor.min_scaled_jacobian) continue;
        const bool better = plain.valid ? corrected >= plain.min_scaled_jacobian
                                        : follow(CurveSideBlend{1, all_sides}) > plain.min_scaled_jacobian;
        if (!better) hm.face_nodes.middleRows(static_cast<Eigen::Index>(f) * npf, npf) = kept;
      }
    });
  }
  // A face that a neighbour's exact surface takes below the quality floor goes back to the blend
  // of its corner fits, with its edges that surface placed: the repair would pull it toward
  // straight (a marching-tetrahedra torus's caps and needles: P4 2.5e-6 -> 6.2e-5). Set-based:
  // the result does not depend on the order.
  if (face_fits) {
    std::vector<char> revert(nf, 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, nf), [&](const tbb::blocked_range<int>& r) {
      for (int f = r.begin(); f < r.end(); ++f) {
        bool on_fit = face_fit[f] != nullptr;
        for (int j = 0; j < 3; ++j) on_fit = on_fit || edge_on_face_fit[T.FE(f, j)];
        revert[f] = on_fit && !check_element(basis, element_nodes(hm, f), floor).valid;
      }
    });
    for (int f = 0; f < nf; ++f)
      if (revert[f]) {
        if (face_fit[f]) {
          face_fit[f] = nullptr;
          place_face(f);
        }
        for (int j = 0; j < 3; ++j)
          if (edge_on_face_fit[T.FE(f, j)]) place_edge(T.FE(f, j), true);
      }
    for (int f = 0; f < nf; ++f) R.face_exact_fits += face_fit[f] != nullptr;
  }
  R.face_on_exact.assign(nf, 0);
  for (int f = 0; f < nf; ++f) R.face_on_exact[f] = face_fit[f] != nullptr;
  for (int e = 0; e < ne; ++e) {
    R.curve_edges += on_curve[e];
    R.crossing_edges += R.crossing[e];
    R.long_edges += long_edge && long_edge->unreached[e] && !on_curve[e];
  }
  R.seconds = seconds_since(t0);
  return R;
}

}  // namespace hocurve
