#include "engine/curving/cone_points.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

namespace {

/// Whether the surface around v descends from it along straight rulings (a cone) rather than
/// curving away (a smooth point) or dropping to a plane (a lone spike of noise). Each 2-ring vertex
/// w is paired with the 1-ring vertex u nearest its direction; with s the sine of elevation over the
/// fan normal n and r the distance, s_w / s_u = (r_w / r_u)^e: e ~ 0 on a cone (a ruling keeps its
/// slope), ~1 on a smooth surface (the elevation grows with the distance), ~-1 for a spike (the same
/// drop at any distance). True when the median e is nearer 0 than both.
/// ring = v's 1-ring, then the rest of its 2-ring sorted (it may hold v and 1-ring vertices again);
/// returns the 1-ring's size.
long two_ring(const Topology& T, int v, std::vector<int>& ring) {
  ring.clear();
  auto [eb, ee] = T.edges_of(v);
  for (const int* e = eb; e != ee; ++e) ring.push_back(T.other(*e, v));
  const long n1 = static_cast<long>(ring.size());
  for (long i = 0; i < n1; ++i)
    for (auto [fb, fe] = T.edges_of(ring[i]); fb != fe; ++fb) ring.push_back(T.other(*fb, ring[i]));
  std::sort(ring.begin() + n1, ring.end());
  ring.erase(std::unique(ring.begin() + n1, ring.end()), ring.end());
  return n1;
}

/// How far v lies from the quadric height function z(x, y) over the fan normal n fitted to its
/// 2-ring without it, over the 1-ring's mean edge length h. A smooth surface's quadric predicts v
/// to O(h^3); a cone's rings round its apex off by ~0.65 h cot(half-angle). -1: too few points.
double apex_miss(const Mesh& mesh, int v, const Eigen::Vector3d& n, const std::vector<int>& ring, long n1) {
  const Eigen::Vector3d o = mesh.V.row(v).transpose();
  double h = 0;
  for (long i = 0; i < n1; ++i) h += (mesh.V.row(ring[i]).transpose() - o).norm();
  h /= static_cast<double>(n1);
  const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  Eigen::MatrixXd A(static_cast<long>(ring.size()), 6);
  Eigen::VectorXd z(A.rows());
  long rows = 0;
  for (size_t i = 0; i < ring.size(); ++i) {
    if (ring[i] == v || (i >= static_cast<size_t>(n1) && std::find(ring.begin(), ring.begin() + n1, ring[i]) != ring.begin() + n1))
      continue;
    const Eigen::Vector3d d = (mesh.V.row(ring[i]).transpose() - o) / h;
    const double x = d.dot(t1), y = d.dot(t2);
    A.row(rows) << 1, x, y, x * x, x * y, y * y;
    z(rows++) = d.dot(n);
  }
  if (rows < 9) return -1;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A.topRows(rows));
  if (qr.rank() < 6) return -1;
  const Eigen::VectorXd c = qr.solve(z.head(rows));
  return std::abs(c(0));
}

bool descends_like_cone(const Mesh& mesh, const Topology& T, int v, const Eigen::Vector3d& n, std::vector<int>& ring,
                        std::vector<double>& exps) {
  const Eigen::Vector3d o = mesh.V.row(v).transpose();
  const long n1 = two_ring(T, v, ring);
  auto unit_tangent = [&](const Eigen::Vector3d& d) { return (d - d.dot(n) * n).normalized(); };
  exps.clear();
  for (size_t i = static_cast<size_t>(n1); i < ring.size(); ++i) {
    const int w = ring[i];
    if (w == v || std::find(ring.begin(), ring.begin() + n1, w) != ring.begin() + n1) continue;
    const Eigen::Vector3d dw = mesh.V.row(w).transpose() - o;
    const Eigen::Vector3d tw = unit_tangent(dw);
    int best = -1;
    double best_cos = -2;
    for (long k = 0; k < n1; ++k) {
      const double c = unit_tangent(mesh.V.row(ring[k]).transpose() - o).dot(tw);
      if (c > best_cos) best_cos = c, best = ring[k];
    }
    if (best < 0 || !(best_cos > 0.9)) continue;
    const Eigen::Vector3d du = mesh.V.row(best).transpose() - o;
    const double rw = dw.norm(), ru = du.norm(), sw = dw.dot(n) / rw, su = du.dot(n) / ru;
    if (!(rw > 1.3 * ru) || !(sw * su > 0)) continue;
    exps.push_back(std::log(sw / su) / std::log(rw / ru));
  }
  if (exps.size() < 3) return false;
  const auto mid = exps.begin() + static_cast<long>(exps.size() / 2);
  std::nth_element(exps.begin(), mid, exps.end());
  return std::abs(*mid) < 0.5;
}

}  // namespace

std::vector<char> cone_points(const Mesh& mesh, const Topology& T, const std::vector<char>& vertex_feature,
                              const ConeOptions& opt) {
  const int nv = mesh.num_vertices();
  // Angle defect and a third of the fan's area, for vertices whose fan is closed (as many edges as
  // faces, each edge shared by two faces) and off the features.
  std::vector<double> defect(nv, 0), area(nv, 0);
  std::vector<Eigen::Vector3d> normal(nv, Eigen::Vector3d::Zero());
  std::vector<char> closed(nv, 0);
  for (int v = 0; v < nv; ++v) {
    if (!vertex_feature.empty() && vertex_feature[v]) continue;
    auto [eb, ee] = T.edges_of(v);
    auto [fb, fe] = T.faces_of(v);
    if (ee - eb != fe - fb || fe == fb) continue;
    if (!std::all_of(eb, ee, [&](int e) { return T.edge_faces[e].size() == 2; })) continue;
    double angles = 0, a = 0;
    for (const int* f = fb; f != fe; ++f) {
      int j = 0;
      while (mesh.F(*f, j) != v) ++j;
      const Eigen::Vector3d o = mesh.V.row(v), p = mesh.V.row(mesh.F(*f, (j + 1) % 3)), q = mesh.V.row(mesh.F(*f, (j + 2) % 3));
      const Eigen::Vector3d u = p - o, w = q - o;
      angles += std::atan2(u.cross(w).norm(), u.dot(w));
      a += 0.5 * u.cross(w).norm() / 3;
      normal[v] += u.cross(w);
    }
    if (!(a > 0)) continue;
    closed[v] = 1;
    defect[v] = 2 * std::numbers::pi - angles;
    area[v] = a;
  }
  const double min_defect = opt.min_defect_deg * std::numbers::pi / 180;
  const double min_blunt = opt.min_blunt_defect_deg * std::numbers::pi / 180;
  std::vector<char> cone(nv, 0);
  std::vector<double> k;
  std::vector<int> ring;
  std::vector<double> exps;
  for (int v = 0; v < nv; ++v) {
    if (!closed[v] || std::abs(defect[v]) <= min_blunt) continue;
    if (std::abs(defect[v]) <= min_defect &&
        !(normal[v].norm() > 0 && descends_like_cone(mesh, T, v, normal[v].normalized(), ring, exps)))
      continue;
    k.clear();
    auto [eb, ee] = T.edges_of(v);
    for (const int* e = eb; e != ee; ++e) {
      const int u = T.other(*e, v);
      if (closed[u]) k.push_back(std::abs(defect[u]) / area[u]);
    }
    if (k.empty()) continue;  // every neighbour on a feature: a corner's business, not a cone's
    // 8x every neighbour, not only most of them: the vertices of a weak crease share theirs along
    // it, a lone spike's neighbours make up for it, a small blend between fillets spreads it.
    cone[v] = std::abs(defect[v]) / area[v] > opt.curvature_ratio * *std::max_element(k.begin(), k.end());
    // A smooth surface's rings predict v; a cone's round its apex off (apex_miss). Irregular
    // meshes (marching tetrahedra: a vertex amid slivers) can pass the ratio test by their areas.
    if (cone[v] && normal[v].norm() > 0) {
      const long n1 = two_ring(T, v, ring);
      const double miss = apex_miss(mesh, v, normal[v].normalized(), ring, n1);
      if (miss >= 0 && miss < opt.min_apex_miss * std::sqrt(std::abs(defect[v]) / std::numbers::pi)) cone[v] = 0;
    }
  }
  return cone;
}

}  // namespace hocurve
