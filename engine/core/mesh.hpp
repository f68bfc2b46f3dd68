// The linear triangle surface mesh every stage starts from.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <string>
#include <vector>

namespace hocurve {

/// A named physical group of surface entities, as in Gmsh (dimension 2 only).
struct PhysicalGroup {
  int tag = 0;
  std::string name;              ///< may be empty
  std::vector<int> entities;     ///< surface entity tags that belong to the group
};

/// Linear triangle surface mesh, libigl style: V is #V x 3 positions, F is #F x 3 vertex
/// indices (0-based, counter-clockwise seen from outside when orientable).
/// face_entity holds the Gmsh surface entity tag of each face (empty: all faces in entity 1),
/// so outputs keep the input's entities and physical groups.
struct Mesh {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  Eigen::VectorXi face_entity;
  std::vector<PhysicalGroup> physicals;

  int num_vertices() const { return static_cast<int>(V.rows()); }
  int num_faces() const { return static_cast<int>(F.rows()); }
  /// Entity tag of face f (1 when the mesh carries no entities).
  int entity_of(int f) const { return face_entity.size() ? face_entity[f] : 1; }
};

/// Unnormalised normal of face f, (b - a) x (c - a), as oriented in the input (zero for a face of
/// zero area).
inline Eigen::Vector3d face_normal(const Mesh& mesh, int f) {
  const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  return (b - a).cross(c - a);
}

/// The distinct corners of the faces [first, last) (face indices), sorted.
inline std::vector<int> face_corners(const Mesh& mesh, const int* first, const int* last) {
  std::vector<int> v;
  v.reserve(3 * (last - first));
  for (const int* f = first; f != last; ++f)
    for (int j = 0; j < 3; ++j) v.push_back(mesh.F(*f, j));
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

/// A straight triangle has zero area when |e1 x e2| <= kZeroArea x (its longest edge)^2: its
/// smallest height is below ~1e-12 of its longest edge. One tolerance for every stage, so the
/// input report and the validity check count the same faces.
inline constexpr double kZeroArea = 1e-12;

}  // namespace hocurve
