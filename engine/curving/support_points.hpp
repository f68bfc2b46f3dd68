// The intermediate support structure: seeded random area-weighted samples on the input
// triangles. They sit on the flat facets, so fits must lift them before trusting them.
#pragma once
#include "engine/core/mesh.hpp"

#include <Eigen/Core>
#include <cstdint>

namespace hocurve {

struct SupportOptions {
  double per_face = 3.0;     ///< mean samples per face (total = per_face * #F, area-weighted)
  std::uint64_t seed = 1;    ///< same seed, same samples, whatever the thread count
};

struct SupportPoints {
  Eigen::MatrixXd P;         ///< #S x 3 positions on the facets
  Eigen::VectorXi face;      ///< #S: the face each sample lies on
  Eigen::MatrixXd bary;      ///< #S x 3 barycentric coordinates in that face
  double total_area = 0;     ///< sum of face areas (stats)
  long long faces_without_samples = 0;  ///< faces that drew no sample (stats)
  int count() const { return static_cast<int>(P.rows()); }
};

/// splitmix64 finaliser: a bijective 64-bit mix (counter-based random streams).
std::uint64_t splitmix64(std::uint64_t x);

/// Uniform number in [0,1) that depends only on (seed, i, k): random streams that do not
/// depend on evaluation order or thread count.
double counter_uniform(std::uint64_t seed, std::uint64_t i, std::uint64_t k);

/// Area-weighted random samples on the mesh (deterministic for a seed).
SupportPoints sample_support(const Mesh& mesh, const SupportOptions& opt = {});

}  // namespace hocurve
