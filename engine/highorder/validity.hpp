// Validity of curved triangles: the signed Jacobian determinant against the straight
// triangle's normal, bounded by its Bernstein (Bezier) coefficients, and a repair that
// pulls invalid elements toward their straight shape.
#pragma once
#include "engine/highorder/bezier.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace hocurve {

struct ValidityOptions {
  int max_subdivisions = 4;     ///< Bezier subdivision depth when bounds are undecided; undecided = invalid
  double min_scaled_jacobian = 0.0;  ///< an element is valid when min J / J_straight exceeds this (strictly)
  /// repair: an element's high-order displacement is scaled by this per round; with bisect, in the
  /// quality_floor pass, by the largest factor that clears the floor alone (from its second round
  /// on at most this).
  double shrink = 0.8;
  /// Why bisect: a valid element just below the floor (thin, along a curved edge) needs 1% of its
  /// displacement taken off, and the fixed step took off 20% of the curvature of every edge it
  /// shares. Measured (bench/accuracy.py, max error): T20 d/20 P4 2.4e-2 -> 1.35e-2; the analytic
  /// shapes and the screw unchanged. Not for invalid elements, whose nodes are suspect (bulging
  /// fits): there the larger steps smooth more, and bisection measured worse (P4 deviation from
  /// the input: ktoolcav 0.84 -> 0.93%, hinge 0.43 -> 0.44%; coarse lifting at 4%, after the
  /// re-decimation rounds, 6 of 9 shared meshes worse: armadillo 0.338 -> 0.441%). Except, where
  /// bisect is on, invalid elements that fail at their corners only, and there barely: two sides
  /// leaving a corner along one tangent, as where two feature curves touch (T20's nut chamfer).
  bool bisect = true;
  int max_shrink_steps = 30;    ///< repair: after this the element's nodes go fully straight
  /// repair: valid elements whose min J / J_straight is at or below this also move toward straight
  /// until they clear it (0: only invalid ones). Elements near folding (1e-6..1e-4 on CAD exports,
  /// scans and coarse meshes) are valid but poor for solvers; Gmsh's high-order optimizer aims at
  /// 0.1. Why 0.01: it moved nothing on the analytic benchmark shapes, T20 or the screw, and of the
  /// coarse benchmarks only spot (refined from 4%: 0.404 -> 0.430% of the diagonal); 0.1 cost T20
  /// d/40 P4 3.4e-3 -> 4.6e-3 and coarse Hausdorff up to 14%.
  double quality_floor = 0.01;
  /// repair: invalid needles whose shortest edge is below this x their longest first have their
  /// long edges aligned (align_needles) before any is pulled toward straight (0: never): two
  /// corners that nearly meet (marching tetrahedra: 3e-6 apart, 0.14 long). Measured P4 on the
  /// marching-tetrahedra torus at grid 32 with --long-edge-ratio 0: 2.73e-3 -> 5.2e-6 (linear
  /// 6.9e-3). At 0.01 a CAD needle of king 1.45 long kept a bulge the repair used to flatten (P6
  /// deviation from the input 0.42 -> 1.03%); at 0.001 no shared mesh changes.
  double needle_short_edge = 0.001;
};

/// Per-element result: certified lower bound of J/J_straight over the element and the verdict.
struct ElementValidity {
  double min_scaled_jacobian = 0;  ///< lower bound (Bezier) of det J / det J_straight
  double max_scaled_jacobian = 0;  ///< upper bound
  bool valid = false;
  bool degenerate = false;         ///< straight triangle of (near) zero area: J_straight ~ 0
  int subdivisions = 0;            ///< deepest subdivision level visited (0: decided on the whole element)
};

/// Per-order matrices of the Jacobian bound, built once per order and reused for every element
/// of that order (owned by the caller: no global cache). p = 1..10; d = 2(p-1).
struct JacobianBasis {
  explicit JacobianBasis(int p);
  int p = 1;                                ///< element order
  int d = 0;                                ///< degree of J, 2(p-1)
  int num_nodes = 3;                        ///< (p+1)(p+2)/2
  int num_coefficients = 1;                 ///< (d+1)(d+2)/2
  Eigen::MatrixXd to_bernstein;             ///< #nodes x #nodes: Gmsh-ordered nodes -> control points
  BernsteinProduct product;                 ///< degree (p-1) x (p-1) product of the derivative nets
  Eigen::MatrixXd lattice_values;           ///< T_d: J at the degree-d lattice = T_d b
  Eigen::MatrixXd lattice_to_bernstein;     ///< T_d^{-1} (route A)
  Eigen::MatrixXd grad_u, grad_v;           ///< Lagrange basis gradients at the degree-d lattice (route A)
  std::array<Eigen::MatrixXd, 4> children;  ///< subdivision matrices S_c (bernstein_subdivision_matrix)
};

/// Bernstein coefficients of the scaled Jacobian J / J_straight (degree 2(p-1), Bernstein
/// numbering of bezier.hpp), J = (x_u x x_v) . n with n the unit normal of the straight triangle
/// through the corners. Route B: exact products of the control nets' derivative nets.
/// Returns an empty vector when the straight triangle is degenerate.
Eigen::VectorXd jacobian_bezier(const JacobianBasis& basis, const Eigen::MatrixXd& nodes);

/// Same coefficients by route A: J sampled at the degree-d lattice (Lagrange gradients), then
/// converted with T_d^{-1}. Agrees with jacobian_bezier to rounding; used to cross-check.
Eigen::VectorXd jacobian_bezier_sampled(const JacobianBasis& basis, const Eigen::MatrixXd& nodes);

/// Lower bound of a degree-d Bernstein polynomial (coefficients b) after `depth` uniform
/// subdivisions: the minimum coefficient over all 4^depth children. Non-decreasing in depth.
double bezier_lower_bound(const JacobianBasis& basis, const Eigen::VectorXd& b, int depth);

/// Checks one element given its nodes in Gmsh order (#nodes x 3) and its order p.
/// Builds a JacobianBasis each call: in loops use the overload below with a basis built once.
ElementValidity check_element(const Eigen::MatrixXd& nodes, int p, const ValidityOptions& opt = {});

/// Checks one element with a prebuilt basis for its order (basis.p). Decision: J sampled at the
/// degree-d lattice <= threshold anywhere -> invalid (certain); min Bernstein coefficient >
/// threshold -> valid (certain); otherwise split into 4 children at the edge midpoints, up to
/// opt.max_subdivisions levels; still undecided -> invalid.
ElementValidity check_element(const JacobianBasis& basis, const Eigen::MatrixXd& nodes,
                              const ValidityOptions& opt = {});

struct ValidityReport {
  long long checked = 0;
  long long invalid_before = 0;   ///< elements invalid before repair
  long long repaired = 0;         ///< elements (or neighbours) whose nodes were pulled back
  long long below_floor_before = 0;  ///< valid elements at or below quality_floor before its pass
  long long quality_repaired = 0;    ///< elements moved by the quality_floor pass
  long long needles_aligned = 0;     ///< invalid needles whose long edges were aligned first
  /// Still invalid after repair (check_validity: = invalid_before). 0 unless the input is degenerate
  /// or straight elements themselves miss min_scaled_jacobian (e.g. Lobatto nodes read as equispaced).
  long long invalid_after = 0;
  long long degenerate_input = 0; ///< straight triangles with (near) zero area: cannot be valid
  /// Smallest lower bound of J / J_straight over the non-degenerate elements after repair (0 if none).
  double min_scaled_jacobian = 0;
  std::vector<int> invalid_faces; ///< faces still invalid
};

/// Checks every element of hm (TBB-parallel, deterministic).
ValidityReport check_validity(const HighOrderMesh& hm, const ValidityOptions& opt = {});

/// Per-element results for every face of hm (TBB-parallel, deterministic).
std::vector<ElementValidity> check_elements(const HighOrderMesh& hm, const ValidityOptions& opt = {});

/// Checks and repairs: invalid elements have their high-order displacement (edge and face
/// nodes relative to the straight positions) shrunk step by step; shared edge nodes move for
/// both neighbours, so neighbours are re-checked until every element is valid. floor_checks:
/// when not empty, every element's check at the quality floor (check_elements with
/// min_scaled_jacobian = quality_floor) of hm as it is now, e.g. the untangling's; they are
/// updated instead of checking every element again.
ValidityReport repair_validity(HighOrderMesh& hm, const ValidityOptions& opt = {},
                               std::vector<ElementValidity> floor_checks = {});

}  // namespace hocurve
