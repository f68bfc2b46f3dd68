// Validity of curved triangles: the signed Jacobian determinant against the straight
// triangle's normal, bounded by its Bernstein (Bezier) coefficients, and a repair that
// pulls invalid elements toward their straight shape.
#pragma once
#include "engine/highorder/high_order_mesh.hpp"

#include <Eigen/Core>
#include <vector>

namespace hocurve {

struct ValidityOptions {
  int max_subdivisions = 4;     ///< Bezier subdivision depth when bounds are undecided; undecided = invalid
  double min_scaled_jacobian = 0.0;  ///< an element is valid when min J / J_straight exceeds this (strictly)
  double shrink = 0.8;          ///< repair: displacement factor per step
  int max_shrink_steps = 30;    ///< repair: after this the element's nodes go fully straight
};

/// Per-element result: certified lower bound of J/J_straight over the element and the verdict.
struct ElementValidity {
  double min_scaled_jacobian = 0;  ///< lower bound (Bezier) of det J / det J_straight
  double max_scaled_jacobian = 0;  ///< upper bound
  bool valid = false;
};

/// Checks one element given its nodes in Gmsh order (#nodes x 3) and its order p.
ElementValidity check_element(const Eigen::MatrixXd& nodes, int p, const ValidityOptions& opt = {});

struct ValidityReport {
  long long checked = 0;
  long long invalid_before = 0;   ///< elements invalid before repair
  long long repaired = 0;         ///< elements (or neighbours) whose nodes were pulled back
  long long invalid_after = 0;    ///< still invalid after repair (must be 0 unless the input is degenerate)
  long long degenerate_input = 0; ///< straight triangles with (near) zero area: cannot be valid
  double min_scaled_jacobian = 0; ///< over all elements after repair
  std::vector<int> invalid_faces; ///< faces still invalid
};

/// Checks every element of hm (TBB-parallel, deterministic).
ValidityReport check_validity(const HighOrderMesh& hm, const ValidityOptions& opt = {});

/// Checks and repairs: invalid elements have their high-order displacement (edge and face
/// nodes relative to the straight positions) shrunk step by step; shared edge nodes move for
/// both neighbours, so neighbours are re-checked until every element is valid.
ValidityReport repair_validity(HighOrderMesh& hm, const ValidityOptions& opt = {});

}  // namespace hocurve
