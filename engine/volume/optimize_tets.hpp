// Untangling and optimizing curved tets with the boundary held fixed: the free nodes (inside
// high-order nodes and inside vertices) of poor tets move to raise the smallest Bernstein
// coefficient of det J, the certified bound check_tet uses.
#pragma once
#include "engine/volume/tet_jacobian.hpp"
#include "engine/volume/tet_mesh.hpp"

namespace hocurve {

struct TetOptimizeOptions {
  /// A tet is poor while its smallest det J coefficient is below this x det J of its straight
  /// tet (corners as the optimization starts); negative ones are tangled. Why 0.2 and not just > 0: a positive bound near 0
  /// is a nearly folded element for a solver, and moving it further costs nothing elsewhere.
  double target = 0.2;
  int max_sweeps = 40;     ///< Gauss-Seidel sweeps over the free nodes
  int rings = 0;           ///< free nodes: those of poor tets and of tets this many node-rings around
  int steps_per_node = 12; ///< ascent steps per node and sweep, each with an exact line search
};

struct TetOptimizeResult {
  long long poor_before = 0, tangled_before = 0;  ///< tets below target / with a coefficient <= 0
  long long poor_after = 0, tangled_after = 0;
  long long free_nodes = 0;   ///< nodes moved in the last sweep's set
  int sweeps = 0;
  double seconds = 0;
};

/// Improves tm in place; nodes with tm.fixed set never move. TBB-parallel: the free nodes are
/// coloured so that no two of one colour share a tet, and each colour moves at once.
TetOptimizeResult optimize_tets(TetMesh& tm, const TetJacobianBasis& basis, const TetOptimizeOptions& opt = {});

}  // namespace hocurve
