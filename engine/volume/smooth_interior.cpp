// Jacobi iterations of lattice-neighbour averaging on the node displacements.
#include "engine/volume/smooth_interior.hpp"

#include "engine/highorder/reference_nodes.hpp"

#include <tbb/parallel_for.h>

namespace hocurve {

void smooth_interior(TetMesh& tm, const SmoothOptions& opt) {
  const int p = tm.order, n = static_cast<int>(tm.T.cols()), N = static_cast<int>(tm.X.rows());
  if (p < 2 || tm.num_tets() == 0) return;
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
  // Region: tets touching the boundary by more than a vertex, grown by rings through nodes.
  std::vector<char> in(tm.num_tets(), 0), node_in(N, 0);
  for (int t = 0; t < tm.num_tets(); ++t)
    for (int k = 4; k < n && !in[t]; ++k) in[t] = tm.fixed[tm.T(t, k)];
  for (int ring = 0; ring <= opt.rings; ++ring) {
    std::fill(node_in.begin(), node_in.end(), 0);
    for (int t = 0; t < tm.num_tets(); ++t)
      if (in[t])
        for (int k = 0; k < n; ++k) node_in[tm.T(t, k)] = 1;
    if (ring == opt.rings) break;
    for (int t = 0; t < tm.num_tets(); ++t)
      for (int k = 0; k < n && !in[t]; ++k) in[t] = node_in[tm.T(t, k)];
  }
  // Lattice neighbour pairs of one tet: barycentric indices differing by e_i - e_j.
  std::vector<std::pair<int, int>> pairs;
  for (int k = 0; k < n; ++k)
    for (int l = 0; l < n; ++l) {
      const Eigen::Vector3i d = L.row(k) - L.row(l);
      const int a = d.cwiseAbs().sum(), s = d.sum();
      if ((a == 1) || (a == 2 && s == 0)) pairs.emplace_back(k, l);
    }
  // Nodes moving at the boundary of the region keep d = 0: only nodes all of whose tets are
  // in the region move.
  std::vector<char> moves(N, 0);
  for (int i = 0; i < N; ++i) moves[i] = node_in[i] && !tm.fixed[i];
  for (int t = 0; t < tm.num_tets(); ++t)
    if (!in[t])
      for (int k = 0; k < n; ++k) moves[tm.T(t, k)] = 0;
  std::vector<int> region;
  for (int t = 0; t < tm.num_tets(); ++t)
    if (in[t]) region.push_back(t);

  Eigen::MatrixXd sum(N, 3);
  std::vector<int> count(N);
  for (int it = 0; it < opt.iterations; ++it) {
    sum.setZero();
    std::fill(count.begin(), count.end(), 0);
    for (int t : region)
      for (const auto& [k, l] : pairs) {
        const int a = tm.T(t, k);
        if (!moves[a]) continue;
        sum.row(a) += D.row(tm.T(t, l));
        ++count[a];
      }
    tbb::parallel_for(0, N, [&](int i) {
      if (count[i]) D.row(i) = sum.row(i) / count[i];
    });
  }
  for (int i = 0; i < N; ++i)
    if (moves[i]) tm.X.row(i) = S.row(i) + D.row(i);
}

}  // namespace hocurve
