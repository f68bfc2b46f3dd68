#include "engine/curving/long_edges.hpp"

#include <Eigen/Geometry>
#include <algorithm>

namespace hocurve {

bool smooth_surface(const Features& features, const Topology& T, const std::vector<int>& planar,
                    const LongEdgeOptions& opt) {
  long long creases = 0;
  for (int e = 0; e < T.num_edges(); ++e) creases += features.edge_feature[e] && T.edge_faces[e].size() == 2;
  return creases < opt.smooth_feature_share * static_cast<double>(T.num_edges()) &&
         std::none_of(planar.begin(), planar.end(), [](int anchor) { return anchor >= 0; });
}

LongEdgeResult long_edges(const Mesh& mesh, const Topology& T, const Wedges& W, const std::vector<LocalFit>& fits,
                          const LongEdgeOptions& opt, const std::vector<const LocalFit*>* face_fits) {
  LongEdgeResult R;
  R.options = opt;
  const int ne = T.num_edges(), nv = mesh.num_vertices(), nf = mesh.num_faces();
  R.edge.assign(ne, 0);
  R.unreached.assign(ne, 0);
  R.face.assign(nf, 0);
  if (!(opt.ratio > 0)) return R;
  std::vector<double> length(ne), median(nv, 0), around;
  for (int e = 0; e < ne; ++e) length[e] = (mesh.V.row(T.E(e, 0)) - mesh.V.row(T.E(e, 1))).norm();
  for (int v = 0; v < nv; ++v) {
    auto [b, end] = T.edges_of(v);
    if (b == end) continue;
    around.clear();
    for (const int* e = b; e != end; ++e) around.push_back(length[*e]);
    std::nth_element(around.begin(), around.begin() + around.size() / 2, around.end());
    median[v] = around[around.size() / 2];
  }
  for (int e = 0; e < ne; ++e) {
    R.edge[e] = length[e] > opt.ratio * median[T.E(e, 0)] || length[e] > opt.ratio * median[T.E(e, 1)];
    R.edges += R.edge[e];
  }
  auto on_exact_surface = [&](int e) {
    return face_fits && std::any_of(T.edge_faces[e].begin(), T.edge_faces[e].end(),
                                    [&](int f) { return (*face_fits)[f] != nullptr; });
  };
  // The end fits of an edge are its faces' corner fits there (one wedge per side of a feature;
  // edges off the features have the same wedge at each end in both faces).
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      const int e = T.FE(f, j);
      if (!R.edge[e] || R.unreached[e] || on_exact_surface(e)) continue;
      const LocalFit &fa = fits[W.corner_wedge(f, j)], &fb = fits[W.corner_wedge(f, (j + 1) % 3)];
      const Eigen::Vector3d a = mesh.V.row(mesh.F(f, j)), b = mesh.V.row(mesh.F(f, (j + 1) % 3)), m = (a + b) / 2;
      const double miss = std::max({(fa.project(b) - b).norm(), (fb.project(a) - a).norm(),
                                    (fa.project(m) - fb.project(m)).norm()});
      R.unreached[e] = miss > opt.fit_miss * length[e];
    }
  for (int f = 0; f < nf; ++f) {
    for (int j = 0; j < 3; ++j) R.face[f] = R.face[f] || R.unreached[T.FE(f, j)];
    R.faces += R.face[f];
  }
  return R;
}

Eigen::Vector3d pn_triangle_point(const Eigen::Matrix3d& P, const Eigen::Matrix3d& N, const Eigen::Vector3d& xi) {
  // Edge control point near corner i on edge (i, j): a third of the way, pushed into i's tangent plane.
  auto b = [&](int i, int j) -> Eigen::Vector3d {
    const Eigen::Vector3d pi = P.row(i).transpose(), pj = P.row(j).transpose(), ni = N.row(i).transpose();
    return (2 * pi + pj - (pj - pi).dot(ni) * ni) / 3;
  };
  const Eigen::Vector3d b01 = b(0, 1), b10 = b(1, 0), b12 = b(1, 2), b21 = b(2, 1), b20 = b(2, 0), b02 = b(0, 2);
  const Eigen::Vector3d mid_edges = (b01 + b10 + b12 + b21 + b20 + b02) / 6;
  const Eigen::Vector3d mid_corners = P.colwise().sum().transpose() / 3;
  const Eigen::Vector3d centre = mid_edges + (mid_edges - mid_corners) / 2;
  const double u = xi[0], v = xi[1], w = xi[2];
  return u * u * u * P.row(0).transpose() + v * v * v * P.row(1).transpose() + w * w * w * P.row(2).transpose() +
         3 * (u * u * v * b01 + u * v * v * b10 + v * v * w * b12 + v * w * w * b21 + w * w * u * b20 + w * u * u * b02) +
         6 * u * v * w * centre;
}

Eigen::Matrix3d same_size_normals(const Mesh& mesh, const Wedges& W, int f, const LongEdgeOptions& opt) {
  auto area_normal = [&](int g) -> Eigen::Vector3d {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(g, 0)), b = mesh.V.row(mesh.F(g, 1)), c = mesh.V.row(mesh.F(g, 2));
    return (b - a).cross(c - a);
  };
  const Eigen::Vector3d nf = area_normal(f);
  Eigen::Matrix3d N;
  for (int j = 0; j < 3; ++j) {
    const int a1 = mesh.F(f, (j + 1) % 3), a2 = mesh.F(f, (j + 2) % 3), w = W.corner_wedge(f, j);
    Eigen::Vector3d n = nf;
    for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
      const int g = W.wedge_faces[i];
      if (g == f) continue;
      bool neighbour = false;  // g shares edge (corner, a1) or (corner, a2) with f
      for (int k = 0; k < 3; ++k) neighbour = neighbour || mesh.F(g, k) == a1 || mesh.F(g, k) == a2;
      const Eigen::Vector3d ng = area_normal(g);
      if (neighbour && ng.norm() >= opt.same_size_area * nf.norm()) n += ng;
    }
    N.row(j) = (n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero()).transpose();
  }
  return N;
}

Eigen::Vector3d long_face_point(const Mesh& mesh, const Wedges& W, int f, const Eigen::Vector3d& xi,
                                const LongEdgeOptions& opt) {
  Eigen::Matrix3d P;
  for (int j = 0; j < 3; ++j) P.row(j) = mesh.V.row(mesh.F(f, j));
  return pn_triangle_point(P, same_size_normals(mesh, W, f, opt), xi);
}

}  // namespace hocurve
