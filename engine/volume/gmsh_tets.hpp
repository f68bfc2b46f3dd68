// Linear tets filling the volumes bounded by a closed surface, by the Gmsh SDK, keeping the
// surface's triangles exactly (no Steiner point on the boundary).
//
// Gmsh's state is process-global: this is the only file that calls Gmsh, and
// generate_linear_tets must never run on two threads at once (nor while the caller holds a
// Gmsh session: it initializes and finalizes Gmsh itself).
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/volume/shells.hpp"

#include <Eigen/Core>

namespace hocurve {

struct LinearTetOptions {
  double size = 0;         ///< target tet size inside (Mesh.MeshSizeMax); 0: from the surface's edges
  double size_factor = 1;  ///< Mesh.MeshSizeFactor on the sizes Gmsh derives
  int algorithm = 1;       ///< Mesh.Algorithm3D: 1 Delaunay (the tested one), 10 HXT
};

/// Linear tets. V: #V x 3, the surface's vertices first (same rows), then the inside vertices
/// Gmsh added. T: #T x 4 vertex indices, positively oriented (det [v1-v0, v2-v0, v3-v0] > 0).
struct LinearTets {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  double seconds = 0;
};

/// Tetrahedralizes every volume of shells (see Shells) with Gmsh. Throws InputError when Gmsh
/// refuses the surface (its message, e.g. a crossing it found) or changed its
/// triangles (boundary recovery inserted Steiner points).
LinearTets generate_linear_tets(const Mesh& surface, const Shells& shells, const LinearTetOptions& opt = {});

}  // namespace hocurve
