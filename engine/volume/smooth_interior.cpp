// Jacobi iterations of lattice-neighbour averaging on the node displacements.
#include "engine/volume/smooth_interior.hpp"

#include "engine/highorder/reference_nodes.hpp"

#include <tbb/parallel_for.h>

namespace hocurve {

void smooth_interior(TetMesh& tm, const std::vector<int>& seeds, const SmoothOptions& opt) {
  const int p = tm.order, n = static_cast<int>(tm.T.cols()), N = static_cast<int>(tm.X.rows());
  if (p < 2 || seeds.empty()) return;
  // Straight positions: the lattice weights on the tet's corners (the same from every tet).
  const Eigen::MatrixXi L = tet_lattice(p);
  Eigen::MatrixXd S(N, 3);
  for (int t = 0; t < tm.num_tets(); ++t)
    for (int k = 0; k < n; ++k) {
      const double w[4] = {double(p - L(k, 0) - L(k, 1) - L(k, 2)) / p, double(L(k, 0)) / p,
                           double(L(k, 1)) / p, double(L(k, 2)) / p};
      Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
      for (int c = 0; c < 4; ++c) x += w[c] * tm.X.row(tm.T(t, c));
      S.row(tm.T(t, k)) = x;
    }
  Eigen::MatrixXd D = tm.X - S;
  for (int i = 0; i < N; ++i)
    if (!tm.fixed[i]) D.row(i).setZero();
  // Region: the seeds grown by rings through nodes.
  std::vector<char> in(tm.num_tets(), 0), node_in(N, 0);
  for (int t : seeds) in[t] = 1;
  for (int ring = 0; ring <= opt.rings; ++ring) {
    std::fill(node_in.begin(), node_in.end(), 0);
    for (int t = 0; t < tm.num_tets(); ++t)
      if (in[t])
        for (int k = 0; k < n; ++k) node_in[tm.T(t, k)] = 1;
    if (ring == opt.rings) break;
    for (int t = 0; t < tm.num_tets(); ++t)
      for (int k = 0; k < n && !in[t]; ++k) in[t] = node_in[tm.T(t, k)];
  }
  // Lattice neighbours of each local node: barycentric indices differing by e_i - e_j.
  std::vector<std::vector<int>> nbr(n);
  for (int k = 0; k < n; ++k)
    for (int l = 0; l < n; ++l) {
      const Eigen::Vector3i d = L.row(k) - L.row(l);
      const int a = d.cwiseAbs().sum(), s = d.sum();
      if (a == 1 || (a == 2 && s == 0)) nbr[k].push_back(l);
    }
  // Only nodes all of whose tets are in the region move; the others keep d (0 inside).
  std::vector<char> moves(N, 0);
  for (int i = 0; i < N; ++i) moves[i] = node_in[i] && !tm.fixed[i];
  for (int t = 0; t < tm.num_tets(); ++t)
    if (!in[t])
      for (int k = 0; k < n; ++k) moves[tm.T(t, k)] = 0;
  std::vector<int> moving;
  for (int i = 0; i < N; ++i)
    if (moves[i]) moving.push_back(i);
  const NodeTets nt(tm);  // a race-free parallel gather
  Eigen::MatrixXd next = D;
  for (int it = 0; it < opt.iterations; ++it) {
    tbb::parallel_for(std::size_t(0), moving.size(), [&](std::size_t j) {
      const int i = moving[j];
      Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
      int count = 0;
      for (int q = nt.start[i]; q < nt.start[i + 1]; ++q) {
        const int t = nt.tets[q];
        int k = 0;
        while (tm.T(t, k) != i) ++k;
        for (int l : nbr[k]) sum += D.row(tm.T(t, l));
        count += static_cast<int>(nbr[k].size());
      }
      if (count) next.row(i) = sum / count;
    });
    D.swap(next);  // rows that do not move are equal in both
  }
  for (int i = 0; i < N; ++i)
    if (moves[i]) tm.X.row(i) = S.row(i) + D.row(i);
}

}  // namespace hocurve
