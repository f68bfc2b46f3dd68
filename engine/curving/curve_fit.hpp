// 1D fits along feature curves: edges on a sharp rim or a boundary curve along the curve
// (not along either adjacent surface), and corners stay put.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"

#include <Eigen/Core>
#include <vector>

namespace hocurve {

/// A curve through o: x(s) = o + s t + y(s) n1 + z(s) n2, y and z interpolatory polynomials
/// (no constant term) in s/h with coefficients cy, cz giving offsets / h. With a reference circle
/// (kappa > 0: radius 1 / kappa, centre o + n1 / kappa, in the plane of t and n1) s is the arc
/// length along the circle, y the offset from it towards its centre and z out of its plane: the
/// circle through the curve's points where they lie on one, else the curve's osculating circle
/// (FitOptions::curve_reference_circle), as the osculating torus for surface fits (local_fit.hpp),
/// so that arcs of CAD rims, holes and fillets are fitted exactly and stencils spanning a large
/// angle converge.
struct CurveFit {
  Eigen::Vector3d o = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::UnitX(),
                  n1 = Eigen::Vector3d::UnitY(), n2 = Eigen::Vector3d::UnitZ();
  double h = 1.0;
  double kappa = 0;  ///< curvature of the reference circle (0: the tangent line)
  int degree = 0;
  Eigen::VectorXd cy, cz;
  int points = 0;
  /// The points (three or more) lie on the reference circle to FitOptions::circle_tolerance:
  /// an arc of a CAD rim, hole or fillet, which the fit follows exactly.
  bool on_circle = false;
  /// (s, y, z) of a point in the fit's chart.
  Eigen::Vector3d coords(const Eigen::Vector3d& q) const;
  /// The fitted curve point at x's parameter s.
  Eigen::Vector3d project(const Eigen::Vector3d& x) const;
};

struct CurveFitResult {
  /// For feature edge e: fits[first[e]] is the fit at E(e,0), fits[first[e] + 1] at E(e,1), each
  /// along the curve through e (one-sided at corners). first[e] is -1 off the features (two
  /// placeholders per edge were most of a scan's curve-fit time and a quarter of its memory).
  std::vector<int> first;
  std::vector<CurveFit> fits;
  /// Feature edge e's fit at its end s (0: E(e,0), 1: E(e,1)).
  const CurveFit& at(int e, int s) const { return fits[first[e] + s]; }
  /// Whether edge e has curve fits.
  bool fitted_edge(int e) const { return !first.empty() && first[e] >= 0; }
  long long fitted = 0, downgraded = 0;
  long long straight = 0;  ///< edges on a line (their ends and a neighbour along the curve collinear)
  double seconds = 0;
};

/// Fits a degree-p curve at vertex v along the feature curve through edge e: the chain of
/// feature vertices on both sides of v (only beyond e when v is a corner), stopping at corners.
CurveFit fit_curve_at(const Mesh& mesh, const Topology& T, const Features& feat, int v, int e,
                      int p, const FitOptions& opt);

/// Fits both ends of every feature edge (TBB-parallel, deterministic).
CurveFitResult fit_feature_curves(const Mesh& mesh, const Topology& T, const Features& feat,
                                  int p, const FitOptions& opt = {});

/// Point at parameter t in [0,1] of feature edge e: the two end fits blended linearly.
Eigen::Vector3d curve_edge_point(const Mesh& mesh, const Topology& T, const CurveFitResult& C,
                                 int e, double t);

}  // namespace hocurve
