// Exact vertex welding: merge points whose coordinates are equal, keeping first-seen order.
#pragma once
#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace hocurve {

/// Result of weld_exact: unique points (x,y,z interleaved, first-seen order) and, for each
/// input point, the index of its unique point.
template <class Real>
struct WeldResult {
  std::vector<Real> points;
  std::vector<int> index;
};

/// Merges points (n x 3, interleaved xyz) whose three coordinates compare equal (bitwise
/// after mapping -0 to +0), with an open-addressing hash on the bit patterns. Deterministic:
/// unique points appear in the order of their first occurrence. NaNs must be rejected before.
WeldResult<float> weld_exact(const float* xyz, std::size_t n);
WeldResult<double> weld_exact(const double* xyz, std::size_t n);

}  // namespace hocurve

namespace hocurve {

/// For each point of V (#V x 3), the lowest-numbered point within distance tol of it through a
/// chain of such pairs (itself when none): near-duplicates (CAD faces tessellated apart, whose
/// shared border points differ in the last digits) map to one. A sorted sweep along one
/// direction; deterministic.
std::vector<int> weld_within(const Eigen::MatrixXd& V, double tol);

}  // namespace hocurve
