// Each free node climbs the soft minimum of its tets' det J coefficients (scaled by their
// straight det J at the start); a step is kept only when the true minimum rises.
#include "engine/volume/optimize_tets.hpp"

#include "engine/core/stopwatch.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hocurve {

namespace {

struct Problem {
  TetMesh& tm;
  const TetJacobianBasis& b;
  std::vector<double> J0;  // det J of each tet's initial straight tet

  Eigen::VectorXd coefficients(int t) const { return b.to_bernstein * jacobian_samples(b, tm.tet_nodes(t)); }
  double quality(int t) const { return coefficients(t).minCoeff() / J0[t]; }

  // det J is affine in the position of any one node (moving it adds the same vector to the
  // three columns, and a determinant with a repeated column vanishes), so each coefficient of
  // each tet of node n is exactly c + G x, x its displacement: one evaluation per node serves a
  // whole line search. Rows: every coefficient of every tet of n, scaled by its J0.
  void linearize(const int* first, const int* last, int n, Eigen::VectorXd& c, Eigen::MatrixXd& G) const {
    const Eigen::Index S = b.to_bernstein.rows();
    c.resize(S * (last - first));
    G.resize(c.size(), 3);
    Eigen::Index row = 0;
    for (const int* t = first; t != last; ++t, row += S) {
      int k = 0;
      while (tm.T(*t, k) != n) ++k;
      const Eigen::MatrixXd X = tm.tet_nodes(*t);
      const Eigen::MatrixXd Xu = b.grad_u * X, Xv = b.grad_v * X, Xw = b.grad_w * X;
      Eigen::VectorXd J(S);
      Eigen::MatrixXd dJ(S, 3);
      for (Eigen::Index s = 0; s < S; ++s) {
        const Eigen::RowVector3d u = Xu.row(s), v = Xv.row(s), w = Xw.row(s);
        J[s] = u.dot(v.cross(w));
        dJ.row(s) = b.grad_u(s, k) * v.cross(w) + b.grad_v(s, k) * w.cross(u) + b.grad_w(s, k) * u.cross(v);
      }
      c.segment(row, S) = b.to_bernstein * J / J0[*t];
      G.middleRows(row, S) = b.to_bernstein * dJ / J0[*t];
    }
  }

  // Ascent of the smallest of c + G x from x = 0 along soft-minimum gradients, with exact
  // line searches; moves node n by the best x found.
  void improve(int n, const NodeTets& nt, const TetOptimizeOptions& opt) const {
    const int *first = nt.tets.data() + nt.start[n], *last = nt.tets.data() + nt.start[n + 1];
    double h = std::numeric_limits<double>::infinity();
    for (const int* t = first; t != last; ++t) h = std::min(h, std::cbrt(J0[*t]));
    Eigen::VectorXd c;
    Eigen::MatrixXd G;
    linearize(first, last, n, c, G);
    Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
    double f = c.minCoeff();
    for (int step = 0; step < opt.steps_per_node && f < opt.target; ++step) {
      const Eigen::VectorXd q = c + G * x.transpose();
      const double beta = 20 / std::max(std::abs(f), 0.05);
      const Eigen::VectorXd w = (-beta * (q.array() - f)).exp().matrix();
      const Eigen::RowVector3d g = w.transpose() * G;
      if (g.norm() == 0) break;
      const Eigen::RowVector3d d = g.normalized();
      const Eigen::VectorXd slope = G * d.transpose();
      double best = f, best_a = 0;
      for (double a = h / 3; a > h * 1e-4; a /= 2) {
        const double fa = (q + a * slope).minCoeff();
        if (fa > best) best = fa, best_a = a;
      }
      if (best_a == 0) break;
      x += best_a * d;
      f = best;
    }
    tm.X.row(n) += x;
  }
};

// Greedy colouring of nodes so that no two of one colour share a tet.
std::vector<std::vector<int>> colour(const std::vector<int>& nodes, const TetMesh& tm, const NodeTets& nt) {
  std::vector<int> col(tm.X.rows(), -1);
  std::vector<std::vector<int>> out;
  std::vector<char> used;
  for (int n : nodes) {
    used.assign(out.size() + 1, 0);
    for (int i = nt.start[n]; i < nt.start[n + 1]; ++i)
      for (Eigen::Index k = 0; k < tm.T.cols(); ++k) {
        const int c = col[tm.T(nt.tets[i], k)];
        if (c >= 0) used[c] = 1;
      }
    const int c = static_cast<int>(std::find(used.begin(), used.end(), 0) - used.begin());
    if (c == static_cast<int>(out.size())) out.emplace_back();
    out[c].push_back(n);
    col[n] = c;
  }
  return out;
}

// Free nodes of the poor tets (q below target) and of the tets opt.rings node-rings around.
std::vector<int> free_nodes(const TetMesh& tm, const NodeTets& nt, const std::vector<double>& q,
                            const TetOptimizeOptions& opt) {
  std::vector<char> region(tm.num_tets(), 0), is_free(tm.X.rows(), 0);
  for (int t = 0; t < tm.num_tets(); ++t) region[t] = q[t] < opt.target;
  for (int ring = 0; ring < opt.rings; ++ring) {
    std::vector<char> grown = region;
    for (int t = 0; t < tm.num_tets(); ++t)
      if (region[t])
        for (Eigen::Index k = 0; k < tm.T.cols(); ++k)
          for (int i = nt.start[tm.T(t, k)]; i < nt.start[tm.T(t, k) + 1]; ++i) grown[nt.tets[i]] = 1;
    region.swap(grown);
  }
  std::vector<int> nodes;
  for (int t = 0; t < tm.num_tets(); ++t)
    if (region[t])
      for (Eigen::Index k = 0; k < tm.T.cols(); ++k) {
        const int n = tm.T(t, k);
        if (!tm.fixed[n] && !is_free[n]) is_free[n] = 1, nodes.push_back(n);
      }
  return nodes;
}

}  // namespace

TetOptimizeResult optimize_tets(TetMesh& tm, const TetJacobianBasis& basis, const TetOptimizeOptions& opt) {
  const auto t0 = Clock::now();
  TetOptimizeResult r;
  Problem pb{tm, basis, std::vector<double>(tm.num_tets())};
  std::vector<double> q(tm.num_tets());
  tbb::parallel_for(0, tm.num_tets(), [&](int t) {
    pb.J0[t] = straight_jacobian(tm.tet_nodes(t));
    q[t] = pb.quality(t);
  });
  auto count = [&](long long& poor, long long& tangled) {
    poor = tangled = 0;
    for (double v : q) poor += v < opt.target, tangled += v <= 0;
  };
  count(r.poor_before, r.tangled_before);
  r.poor_after = r.poor_before, r.tangled_after = r.tangled_before;
  if (r.poor_before == 0) {
    r.seconds = seconds_since(t0);
    return r;
  }

  const NodeTets nt(tm);
  double best = *std::min_element(q.begin(), q.end());
  int stalled = 0;
  for (r.sweeps = 0; r.sweeps < opt.max_sweeps && r.poor_after > 0 && stalled < 3; ++r.sweeps) {
    const std::vector<int> nodes = free_nodes(tm, nt, q, opt);
    r.free_nodes = static_cast<long long>(nodes.size());
    for (const std::vector<int>& c : colour(nodes, tm, nt))
      tbb::parallel_for(std::size_t(0), c.size(), [&](std::size_t i) { pb.improve(c[i], nt, opt); });
    std::vector<char> touched(tm.num_tets(), 0);  // every tet of a free node may have changed
    for (int n : nodes)
      for (int i = nt.start[n]; i < nt.start[n + 1]; ++i) touched[nt.tets[i]] = 1;
    tbb::parallel_for(0, tm.num_tets(), [&](int t) {
      if (touched[t]) q[t] = pb.quality(t);
    });
    count(r.poor_after, r.tangled_after);
    const double now = *std::min_element(q.begin(), q.end());
    stalled = now > best + 1e-6 ? 0 : stalled + 1;
    best = std::max(best, now);
  }
  r.seconds = seconds_since(t0);
  return r;
}

}  // namespace hocurve
