// Carries the curved boundary's displacement into the tets: the first guess the optimizer
// starts from, instead of straight inside nodes.
#pragma once
#include "engine/volume/tet_mesh.hpp"

#include <vector>

namespace hocurve {

struct SmoothOptions {
  int iterations = 60;  ///< Jacobi sweeps; each carries the displacement one lattice step (h/p) further
  int rings = 2;        ///< tets smoothed: the seeds, grown this many node-rings
};

/// Displacement d = X - S of every node from its position S on its straight tet: fixed nodes
/// keep theirs (the curved boundary's), every other node of the region (the tets seeds, e.g.
/// the invalid ones, grown by opt.rings; vertices included)
/// takes the mean of its lattice neighbours' (nodes one lattice step away in a tet),
/// repeatedly: a discrete harmonic extension. Why lattice neighbours and not whole tets: the
/// nodes of one edge share all their tets, so tet means would move them rigidly, leaving a
/// jump at the edge's fixed ends that folds the corners at P4. Why at all: a boundary
/// face bulging into a thin tet (a concave wall, a thin gap) folds the tet when its inside
/// nodes stay straight, the more so at high order where the first inside layer of nodes is
/// only 1/p of the height away; moved along with the wall, they rarely do. TBB-parallel.
void smooth_interior(TetMesh& tm, const std::vector<int>& seeds, const SmoothOptions& opt = {});

}  // namespace hocurve
