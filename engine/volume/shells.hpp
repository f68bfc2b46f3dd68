// The closed shells of a surface and how they nest: which volumes a tet mesher must fill.
#pragma once
#include "engine/core/mesh.hpp"

#include <vector>

namespace hocurve {

/// Connected closed shells of a surface.
/// - shell_of_face: #F, shell index of each face.
/// - parent[s]: the innermost shell that contains shell s, -1 if none.
/// - depth[s]: how many shells contain s. Shells at even depth bound a volume from outside,
///   their children (depth + 1) are its holes; the inside of a hole is not meshed, but a shell
///   inside it (depth + 2) starts a new volume.
struct Shells {
  int count = 0;
  std::vector<int> shell_of_face;
  std::vector<int> parent, depth;
};

/// Finds the shells of mesh. Throws InputError naming the first open or non-manifold edge
/// (its vertices and coordinates) or the first inconsistently oriented one: a volume needs a
/// closed, manifold, consistently oriented surface.
Shells find_shells(const Mesh& mesh);

/// Winding number of the closed shell s (faces with shell_of_face == s) around point x:
/// about +-1 inside, 0 outside.
double winding_number(const Mesh& mesh, const Shells& shells, int s, const Eigen::Vector3d& x);

}  // namespace hocurve
