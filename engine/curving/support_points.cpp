#include "engine/curving/support_points.hpp"

#include "engine/core/error.hpp"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <cmath>
#include <string>
#include <vector>

namespace hocurve {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double counter_uniform(std::uint64_t seed, std::uint64_t i, std::uint64_t k) {
  // Chained mixing: every input word goes through a full avalanche before the next is added.
  const std::uint64_t h = splitmix64(splitmix64(splitmix64(seed) ^ i) ^ k);
  return static_cast<double>(h >> 11) * 0x1.0p-53;  // 53 random bits -> [0,1)
}

SupportPoints sample_support(const Mesh& mesh, const SupportOptions& opt) {
  if (!(opt.per_face >= 0) || !std::isfinite(opt.per_face))
    throw InputError("support points", "per_face must be a finite number >= 0, got " + std::to_string(opt.per_face));
  const int nf = mesh.num_faces();
  SupportPoints S;
  std::vector<double> area(nf);
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    area[f] = 0.5 * (b - a).cross(c - a).norm();
    S.total_area += area[f];
  }
  std::vector<long long> start(static_cast<size_t>(nf) + 1, 0);
  if (S.total_area > 0 && opt.per_face > 0) {
    // Samples per face: expected count from the area share, stochastic rounding so the total
    // is right on average and each face's count depends only on (seed, face).
    const double scale = opt.per_face * nf / S.total_area;
    for (int f = 0; f < nf; ++f) {
      const double want = scale * area[f];
      const double whole = std::floor(want);
      const long long n = static_cast<long long>(whole) + (counter_uniform(opt.seed, f, 0) < want - whole ? 1 : 0);
      start[f + 1] = start[f] + n;
      if (n == 0) ++S.faces_without_samples;
    }
  } else {
    S.faces_without_samples = nf;
  }
  const long long ns = start[nf];
  S.P.resize(ns, 3);
  S.face.resize(ns);
  S.bary.resize(ns, 3);
  tbb::parallel_for(0, nf, [&](int f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    for (long long s = start[f]; s < start[f + 1]; ++s) {
      const std::uint64_t k = static_cast<std::uint64_t>(s - start[f]);
      // Uniform on the triangle: sqrt of the first variate flattens the density toward vertex a.
      const double r1 = std::sqrt(counter_uniform(opt.seed, f, 2 * k + 1));
      const double r2 = counter_uniform(opt.seed, f, 2 * k + 2);
      const double w0 = 1 - r1, w1 = r1 * (1 - r2), w2 = r1 * r2;
      S.face[s] = f;
      S.bary.row(s) << w0, w1, w2;
      S.P.row(s) = (w0 * a + w1 * b + w2 * c).transpose();
    }
  });
  return S;
}

}  // namespace hocurve
