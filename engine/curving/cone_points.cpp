#include "engine/curving/cone_points.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace hocurve {

std::vector<char> cone_points(const Mesh& mesh, const Topology& T, const std::vector<char>& vertex_feature,
                              const ConeOptions& opt) {
  const int nv = mesh.num_vertices();
  // Angle defect and a third of the fan's area, for vertices whose fan is closed (as many edges as
  // faces, each edge shared by two faces) and off the features.
  std::vector<double> defect(nv, 0), area(nv, 0);
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
    }
    if (!(a > 0)) continue;
    closed[v] = 1;
    defect[v] = 2 * std::numbers::pi - angles;
    area[v] = a;
  }
  const double min_defect = opt.min_defect_deg * std::numbers::pi / 180;
  std::vector<char> cone(nv, 0);
  std::vector<double> k;
  for (int v = 0; v < nv; ++v) {
    if (!closed[v] || std::abs(defect[v]) <= min_defect) continue;
    k.clear();
    auto [eb, ee] = T.edges_of(v);
    for (const int* e = eb; e != ee; ++e) {
      const int u = T.other(*e, v);
      if (closed[u]) k.push_back(std::abs(defect[u]) / area[u]);
    }
    if (k.empty()) continue;  // every neighbour on a feature: a corner's business, not a cone's
    const auto mid = k.begin() + static_cast<long>(k.size() / 2);
    std::nth_element(k.begin(), mid, k.end());
    cone[v] = std::abs(defect[v]) / area[v] > opt.curvature_ratio * *mid;
  }
  return cone;
}

}  // namespace hocurve
