// Garland-Heckbert error quadrics: the summed squared distance to a set of weighted planes.
#pragma once
#include <Eigen/Core>

namespace hocurve {

/// Q(x) = x^T A x + 2 b^T x + c with A symmetric 3x3, stored compactly (10 doubles).
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
  double b0 = 0, b1 = 0, b2 = 0;
  double c = 0;

  Quadric& operator+=(const Quadric& q);
  /// The quadric value at x (>= 0 up to rounding).
  double eval(const Eigen::Vector3d& x) const;
  double trace() const { return a00 + a11 + a22; }
};

/// The quadric of the plane through `point` with unit normal `n`, times `weight`.
Quadric plane_quadric(const Eigen::Vector3d& point, const Eigen::Vector3d& n, double weight);

/// Minimiser of Q(x) + lambda |x - anchor|^2. The isotropic term keeps the solve well posed on
/// flat or cylindrical regions, where A is singular and the plain optimum would run off along the
/// kernel (libigl issue #738); lambda should be small relative to trace(A).
Eigen::Vector3d quadric_minimiser(const Quadric& q, const Eigen::Vector3d& anchor, double lambda);

}  // namespace hocurve
