#include "engine/curving/cone_points.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

namespace {

/// Whether the surface around v descends from it along straight rulings (a cone) rather than
/// curving away (a smooth point): the mean sine of elevation over the fan normal n of the
/// directions to the 2-ring vertices, over that of the 1-ring ones. On a cone each ruling keeps
/// its slope (ratio ~1); on a smooth surface the elevation grows with the distance (ratio ~ the
/// 2-ring's distance over the 1-ring's, ~2); a lone spike drops as far to both (~1/2). True when the
/// ratio is nearer 1 than both.
bool descends_like_cone(const Mesh& mesh, const Topology& T, int v, const Eigen::Vector3d& n, std::vector<int>& ring) {
  const Eigen::Vector3d o = mesh.V.row(v).transpose();
  ring.clear();
  auto [eb, ee] = T.edges_of(v);
  for (const int* e = eb; e != ee; ++e) ring.push_back(T.other(*e, v));
  const size_t n1 = ring.size();
  for (size_t i = 0; i < n1; ++i)
    for (auto [fb, fe] = T.edges_of(ring[i]); fb != fe; ++fb) ring.push_back(T.other(*fb, ring[i]));
  std::sort(ring.begin() + static_cast<long>(n1), ring.end());
  ring.erase(std::unique(ring.begin() + static_cast<long>(n1), ring.end()), ring.end());
  double s[2] = {0, 0}, r[2] = {0, 0};
  int c[2] = {0, 0};
  for (size_t i = 0; i < ring.size(); ++i) {
    const int u = ring[i];
    if (u == v || (i >= n1 && std::find(ring.begin(), ring.begin() + static_cast<long>(n1), u) != ring.begin() + static_cast<long>(n1)))
      continue;
    const Eigen::Vector3d d = mesh.V.row(u).transpose() - o;
    const double len = d.norm();
    if (!(len > 0)) continue;
    const int k = i < n1 ? 0 : 1;
    s[k] += d.dot(n) / len, r[k] += len, ++c[k];
  }
  if (c[0] == 0 || c[1] == 0) return false;
  const double s1 = s[0] / c[0], s2 = s[1] / c[1], rho = (r[1] / c[1]) / (r[0] / c[0]);
  if (!(std::abs(s1) > 0) || s2 / s1 <= 0) return false;
  // A single vertex pushed out of a smooth surface (scan noise) drops the same height to both
  // rings: its ratio is ~1 / rho. Nearer 1 than both is a cone.
  const double t = s2 / s1;
  return t < 0.5 * (1 + rho) && t > 0.5 * (1 + 1 / rho);
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
  for (int v = 0; v < nv; ++v) {
    if (!closed[v] || std::abs(defect[v]) <= min_blunt) continue;
    if (std::abs(defect[v]) <= min_defect &&
        !(normal[v].norm() > 0 && descends_like_cone(mesh, T, v, normal[v].normalized(), ring)))
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
  }
  return cone;
}

}  // namespace hocurve
