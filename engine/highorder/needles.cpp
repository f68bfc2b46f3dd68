#include "engine/highorder/needles.hpp"

#include "engine/core/union_find.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <algorithm>
#include <map>
#include <numeric>

namespace hocurve {

namespace {

double edge_length(const HighOrderMesh& hm, int e) { return (hm.V.row(hm.E(e, 0)) - hm.V.row(hm.E(e, 1))).norm(); }

/// Index j of face f's shortest edge (FE(f, j), corners j and j+1).
int shortest_side(const HighOrderMesh& hm, int f) {
  int best = 0;
  for (int j = 1; j < 3; ++j)
    if (edge_length(hm, hm.FE(f, j)) < edge_length(hm, hm.FE(f, best))) best = j;
  return best;
}

/// Point at parameter s (0 at E(e,0), 1 at E(e,1)) of edge e's Lagrange curve through its ends
/// and nodes at the reference parameters t.
Eigen::RowVector3d curve_point(const HighOrderMesh& hm, int e, const Eigen::VectorXd& t, double s) {
  const int p = hm.order, npe = p - 1;
  Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
  for (int i = 0; i <= p; ++i) {
    double l = 1;
    for (int j = 0; j <= p; ++j)
      if (j != i) l *= (s - t[j]) / (t[i] - t[j]);
    const Eigen::RowVector3d node = i == 0   ? Eigen::RowVector3d(hm.V.row(hm.E(e, 0)))
                                    : i == p ? Eigen::RowVector3d(hm.V.row(hm.E(e, 1)))
                                             : Eigen::RowVector3d(hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + i - 1));
    x += l * node;
  }
  return x;
}

}  // namespace

std::vector<int> needle_faces(const HighOrderMesh& hm, const std::vector<int>& faces, double short_ratio) {
  std::vector<int> out;
  if (!(short_ratio > 0)) return out;
  for (int f : faces) {
    const int j = shortest_side(hm, f);
    const double s = edge_length(hm, hm.FE(f, j));
    const double l = std::max(edge_length(hm, hm.FE(f, (j + 1) % 3)), edge_length(hm, hm.FE(f, (j + 2) % 3)));
    if (s < short_ratio * l) out.push_back(f);
  }
  return out;
}

long long align_needles(HighOrderMesh& hm, const std::vector<int>& needles, double max_offset) {
  const int p = hm.order, npe = p - 1, npf = hm.nodes_per_face();
  if (p < 2 || needles.empty()) return 0;
  const Eigen::VectorXd t = line_reference_nodes(p, hm.distribution);
  // Bundles: the long edges of each needle, joined (parent over the edges that occur).
  std::map<int, int> slot;
  for (int f : needles) {
    const int j = shortest_side(hm, f);
    for (int i : {1, 2}) slot.emplace(hm.FE(f, (j + i) % 3), static_cast<int>(slot.size()));
  }
  std::vector<int> parent(slot.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (int f : needles) {
    const int j = shortest_side(hm, f);
    const int ra = find_root(parent, slot[hm.FE(f, (j + 1) % 3)]), rb = find_root(parent, slot[hm.FE(f, (j + 2) % 3)]);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  // The lowest-numbered edge of each bundle is its master.
  std::vector<int> master(slot.size(), -1);
  for (auto [e, s] : slot) {
    const int r = find_root(parent, s);
    if (master[r] < 0 || e < master[r]) master[r] = e;
  }
  // Edge e becomes master m's curve plus the offsets of its ends from m's nearer ends: at
  // parameter s along e, m at the matching parameter + (1 - s) d0 + s d1.
  auto along_master = [&](int e, int m, double s) {
    const Eigen::RowVector3d e0 = hm.V.row(hm.E(e, 0)), e1 = hm.V.row(hm.E(e, 1));
    const Eigen::RowVector3d m0 = hm.V.row(hm.E(m, 0)), m1 = hm.V.row(hm.E(m, 1));
    const bool same = (e0 - m0).norm() + (e1 - m1).norm() <= (e0 - m1).norm() + (e1 - m0).norm();
    const double sm = same ? s : 1 - s;
    const Eigen::RowVector3d d0 = e0 - (same ? m0 : m1), d1 = e1 - (same ? m1 : m0);
    return Eigen::RowVector3d(curve_point(hm, m, t, sm) + (1 - s) * d0 + s * d1);
  };
  // Only tight bundles: every edge's ends within max_offset of the master's nearer ends (a fan
  // of needles joined edge to edge spreads, and its edges do not follow one curve).
  std::vector<char> tight(slot.size(), 1);
  for (auto [e, s] : slot) {
    const int r = find_root(parent, s), m = master[r];
    const Eigen::RowVector3d e0 = hm.V.row(hm.E(e, 0)), e1 = hm.V.row(hm.E(e, 1));
    const Eigen::RowVector3d m0 = hm.V.row(hm.E(m, 0)), m1 = hm.V.row(hm.E(m, 1));
    const double off = std::min(std::max((e0 - m0).norm(), (e1 - m1).norm()), std::max((e0 - m1).norm(), (e1 - m0).norm()));
    if (!(off <= max_offset * (m1 - m0).norm())) tight[r] = 0;
  }
  long long moved = 0;
  for (auto [e, s] : slot) {
    const int r = find_root(parent, s), m = master[r];
    if (m == e || !tight[r]) continue;
    for (int k = 1; k < p; ++k) hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1) = along_master(e, m, t[k]);
    ++moved;
  }
  const Eigen::MatrixXd ref = triangle_reference_nodes(p, hm.distribution);
  for (int f : needles) {
    const int j = shortest_side(hm, f);
    if (!tight[find_root(parent, slot[hm.FE(f, (j + 1) % 3)])]) continue;
    const int es = hm.FE(f, j), el = hm.FE(f, (j + 1) % 3);
    const Eigen::RowVector3d s0 = hm.V.row(hm.E(es, 0)), s1 = hm.V.row(hm.E(es, 1));
    for (int k = 1; k < p; ++k) hm.edge_nodes.row(static_cast<Eigen::Index>(es) * npe + k - 1) = s0 + t[k] * (s1 - s0);
    if (npf == 0) continue;
    // Face nodes: the long edge (corner j+1 -> far corner j+2) at the far corner's coordinate,
    // plus the offset of the short edge's point from that edge's near end.
    const int near = hm.F(f, (j + 1) % 3), far = hm.F(f, (j + 2) % 3);
    const bool forward = hm.E(el, 0) == near;
    for (int k = 0; k < npf; ++k) {
      const double u = ref(3 * p + k, 0), v = ref(3 * p + k, 1);
      const double lam[3] = {1 - u - v, u, v};
      const double lf = lam[(j + 2) % 3], lo = lam[j];  // far corner, the short edge's other corner
      const Eigen::RowVector3d on_long = curve_point(hm, el, t, forward ? lf : 1 - lf);
      hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k) =
          on_long + lo * (hm.V.row(hm.F(f, j)) - hm.V.row(near));
    }
  }
  return moved;
}

}  // namespace hocurve
