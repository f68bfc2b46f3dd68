// Stages in order, each timed; the surface is checked closed before any work.
#include "engine/volume/volume_mesh.hpp"

#include "engine/core/error.hpp"
#include "engine/core/stopwatch.hpp"
#include "engine/volume/elevate.hpp"
#include "engine/volume/self_intersection.hpp"
#include "engine/volume/shells.hpp"
#include "engine/volume/smooth_interior.hpp"
#include "engine/volume/split_caps.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>

namespace hocurve {

TetMeshQuality check_tet_mesh(const TetMesh& tm, const TetJacobianBasis& basis, const TetCheckOptions& opt) {
  std::vector<TetQuality> q(tm.num_tets());
  tbb::parallel_for(0, tm.num_tets(), [&](int t) { q[t] = check_tet(basis, tm.tet_nodes(t), opt); });
  TetMeshQuality r;
  r.tets = tm.num_tets();
  if (q.empty()) return r;
  r.min_ratio = q[0].min_ratio;
  for (std::size_t t = 0; t < q.size(); ++t) {
    r.min_ratio = std::min(r.min_ratio, q[t].min_ratio);
    if (!q[t].valid) r.invalid_tets.push_back(static_cast<int>(t));
  }
  r.invalid = static_cast<long long>(r.invalid_tets.size());
  r.scaled_jacobian.resize(q.size());
  for (std::size_t t = 0; t < q.size(); ++t) r.scaled_jacobian[t] = q[t].scaled_jacobian;
  auto min_and_p1 = [&](double TetQuality::*field, double& min, double& p1) {
    std::vector<double> s(q.size());
    for (std::size_t t = 0; t < q.size(); ++t) s[t] = q[t].*field;
    std::nth_element(s.begin(), s.begin() + s.size() / 100, s.end());
    p1 = s[s.size() / 100];
    min = *std::min_element(s.begin(), s.end());
  };
  min_and_p1(&TetQuality::scaled_jacobian, r.min_scaled_jacobian, r.p1_scaled_jacobian);
  min_and_p1(&TetQuality::sampled_scaled_jacobian, r.sampled_min_scaled_jacobian, r.sampled_p1_scaled_jacobian);
  return r;
}

VolumeResult volume_mesh(const Mesh& surface, const VolumeOptions& opt) {
  const int p = opt.curve.order;
  if (p < 1 || p > 4) throw UsageError("volume: order " + std::to_string(p) + " out of range 1..4");
  if (opt.curve.distribution != NodeDistribution::Equispaced)
    throw UsageError("volume: tets need equispaced nodes (Gmsh's Lagrange tets)");
  const auto t0 = Clock::now();
  VolumeResult r;
  const Shells shells = find_shells(surface);
  // Gmsh may refuse a crossing without saying where, or mesh around it: check first.
  if (const auto fg = find_self_intersection(surface)) {
    const Eigen::RowVector3d c = surface.V.row(surface.F(fg->first, 0));
    throw InputError("surface faces " + std::to_string(fg->first) + " and " + std::to_string(fg->second) + " near (" +
                         std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " + std::to_string(c[2]) + ")",
                     "self-intersecting: the faces cross");
  }
  r.shells = shells.count;
  r.shells_seconds = seconds_since(t0);

  auto t = Clock::now();
  r.curve = curve_mesh(surface, opt.curve);
  r.curve_seconds = seconds_since(t);

  LinearTets lin = generate_linear_tets(surface, shells, opt.tets);
  r.linear_tets = lin.T.rows();
  r.tets_seconds = lin.seconds;
  if (p > 1) r.split_edges = split_cap_tets(lin, surface);

  t = Clock::now();
  r.mesh = elevate_tets(lin, r.curve.mesh);
  r.elevate_seconds = seconds_since(t);

  const TetJacobianBasis basis(p);
  t = Clock::now();
  const TetMeshQuality before = check_tet_mesh(r.mesh, basis, opt.check);
  r.invalid_before = before.invalid;
  r.check_before_seconds = seconds_since(t);
  if (opt.optimize_enabled) {
    t = Clock::now();
    std::vector<int> seeds;
    for (int k = 0; k < r.mesh.num_tets(); ++k)
      if (before.scaled_jacobian[k] < opt.smooth_below) seeds.push_back(k);
    smooth_interior(r.mesh, seeds, opt.smooth);
    r.smooth_seconds = seconds_since(t);
    r.optimize = optimize_tets(r.mesh, basis, opt.optimize);
  }

  t = Clock::now();
  r.quality = check_tet_mesh(r.mesh, basis, opt.check);
  r.check_seconds = seconds_since(t);
  r.total_seconds = seconds_since(t0);
  return r;
}

}  // namespace hocurve
