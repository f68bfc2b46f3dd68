#include "engine/coarse/quadric.hpp"

#include <Eigen/Dense>

namespace hocurve {

Quadric& Quadric::operator+=(const Quadric& q) {
  a00 += q.a00, a01 += q.a01, a02 += q.a02, a11 += q.a11, a12 += q.a12, a22 += q.a22;
  b0 += q.b0, b1 += q.b1, b2 += q.b2, c += q.c;
  return *this;
}

double Quadric::eval(const Eigen::Vector3d& x) const {
  const double ax0 = a00 * x[0] + a01 * x[1] + a02 * x[2];
  const double ax1 = a01 * x[0] + a11 * x[1] + a12 * x[2];
  const double ax2 = a02 * x[0] + a12 * x[1] + a22 * x[2];
  return x[0] * ax0 + x[1] * ax1 + x[2] * ax2 + 2 * (b0 * x[0] + b1 * x[1] + b2 * x[2]) + c;
}

Quadric plane_quadric(const Eigen::Vector3d& point, const Eigen::Vector3d& n, double w) {
  const double d = -n.dot(point);
  Quadric q;
  q.a00 = w * n[0] * n[0], q.a01 = w * n[0] * n[1], q.a02 = w * n[0] * n[2];
  q.a11 = w * n[1] * n[1], q.a12 = w * n[1] * n[2], q.a22 = w * n[2] * n[2];
  q.b0 = w * d * n[0], q.b1 = w * d * n[1], q.b2 = w * d * n[2];
  q.c = w * d * d;
  return q;
}

Eigen::Vector3d quadric_minimiser(const Quadric& q, const Eigen::Vector3d& anchor, double lambda) {
  Eigen::Matrix3d A;
  A << q.a00 + lambda, q.a01, q.a02, q.a01, q.a11 + lambda, q.a12, q.a02, q.a12, q.a22 + lambda;
  const Eigen::Vector3d rhs = -Eigen::Vector3d(q.b0, q.b1, q.b2) + lambda * anchor;
  Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
  if (ldlt.info() != Eigen::Success || !(ldlt.isPositive())) return anchor;
  Eigen::Vector3d x = ldlt.solve(rhs);
  if (!x.allFinite()) return anchor;
  return x;
}

}  // namespace hocurve
