// Distances between surfaces, for measuring coarse lifting: a uniform-grid closest-point query
// on a triangle mesh, a linear tessellation of curved elements, and a sampled two-sided
// Hausdorff distance.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace hocurve {

/// Uniform grid over a triangle mesh's bounding boxes: exact closest-point distance queries
/// (search in growing shells of cells until no closer triangle can exist).
struct TriangleGrid {
  const Mesh* mesh = nullptr;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  double cell = 1;
  Eigen::Vector3i dims = Eigen::Vector3i::Ones();
  std::vector<int> start, items;  ///< CSR: cell -> triangles overlapping it
  /// Per triangle its bounding box (lo xyz, hi xyz): a triangle whose box is no closer than the
  /// best distance so far is skipped without the exact test.
  std::vector<std::array<double, 6>> boxes;
};

/// Builds the grid (about cells_per_face cells per triangle overall). Keep mesh alive.
TriangleGrid build_triangle_grid(const Mesh& mesh, double cells_per_face = 1.0);

/// Distance from x to the closest triangle of the grid's mesh (face index in *face if given).
double grid_distance(const TriangleGrid& grid, const Eigen::Vector3d& x, int* face = nullptr);

/// Whether a triangle of the grid's mesh is within distance r of x (searches only that far and
/// stops at the first one found).
bool grid_within(const TriangleGrid& grid, const Eigen::Vector3d& x, double r);

/// Linear triangles through an n x n sub-lattice of every curved element (n^2 per element), or
/// only of the elements listed in faces.
Mesh tessellate(const HighOrderMesh& hm, int n, const std::vector<int>* faces = nullptr);

/// Points of every face of mesh at the barycentric lattice of degree n >= 1, each once (points on
/// shared vertices and edges are not repeated).
Eigen::MatrixXd sample_faces(const Mesh& mesh, int n);

struct HausdorffResult {
  double a_to_b = 0, b_to_a = 0;  ///< max over A's samples of the distance to B, and back
  double mean_a_to_b = 0, mean_b_to_a = 0;
  double hausdorff() const { return std::max(a_to_b, b_to_a); }
};

/// Sampled two-sided Hausdorff distance between triangle meshes A and B (faces sampled at the
/// degree-n lattice; exact closest points on the other mesh). TBB-parallel.
HausdorffResult hausdorff_distance(const Mesh& A, const Mesh& B, int n = 4);

/// Per element of the curved mesh hm, its share of the two-sided Hausdorff distance to the dense
/// mesh: the largest distance from the element's degree-n lattice points to the dense mesh, and
/// from the dense faces' degree-dense_n lattice points whose closest point on hm (tessellated
/// n x n) lies in the element. Coarser than hausdorff_distance(dense, tessellate(hm, 8), 4), whose
/// samples are 15 per triangle on both sides, and about 5x faster.
std::vector<double> element_deviation(const HighOrderMesh& hm, const Mesh& dense, int n = 16, int dense_n = 2);

}  // namespace hocurve
