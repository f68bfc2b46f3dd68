#include "engine/curving/planar_patches.hpp"

#include "engine/core/union_find.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace hocurve {

std::vector<int> planar_patch_faces(const Mesh& mesh, const Topology& T, const PlanarPatchOptions& opt,
                                    const std::vector<char>* edge_feature) {
  const int nf = mesh.num_faces();
  std::vector<int> anchor(nf, -1);
  if (!opt.enabled) return anchor;
  std::vector<Eigen::Vector3d> normal(nf);
  std::vector<double> area(nf);
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    area[f] = 0.5 * n.norm();
    normal[f] = area[f] > 0 ? Eigen::Vector3d(n / n.norm()) : Eigen::Vector3d::Zero();
  }
  // Patches: faces joined across manifold edges with (nearly) parallel normals.
  const double cos_tol = std::cos(opt.coplanar_angle);
  std::vector<int> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<char> coplanar_edge(T.num_edges(), 0);
  for (int e = 0; e < T.num_edges(); ++e) {
    const auto& ef = T.edge_faces[e];
    if (ef.size() != 2 || !(area[ef[0]] > 0 && area[ef[1]] > 0)) continue;
    if (normal[ef[0]].dot(normal[ef[1]]) < cos_tol) continue;
    coplanar_edge[e] = 1;
    parent[find_root(parent, ef[0])] = find_root(parent, ef[1]);
  }
  // Per patch: its size, smallest face, the largest face bordering it, and whether a border edge
  // is not a feature.
  std::vector<int> size(nf, 0);
  std::vector<double> smallest(nf, INFINITY), largest_border(nf, 0);
  std::vector<char> smooth_border(nf, edge_feature == nullptr);
  for (int f = 0; f < nf; ++f) {
    const int r = find_root(parent, f);
    ++size[r];
    smallest[r] = std::min(smallest[r], area[f]);
  }
  for (int e = 0; e < T.num_edges(); ++e) {
    if (coplanar_edge[e]) continue;
    const auto& ef = T.edge_faces[e];
    for (int f : ef) {
      if (edge_feature && !(*edge_feature)[e]) smooth_border[find_root(parent, f)] = 1;
      for (int g : ef)
        if (g != f) largest_border[find_root(parent, f)] = std::max(largest_border[find_root(parent, f)], area[g]);
    }
  }
  // Patches holding a vertex with its whole star: every edge around it joins two coplanar faces.
  std::vector<char> star(nf, 0);
  if (opt.whole_star)
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      auto [b, e] = T.edges_of(v);
      if (b == e || !std::all_of(b, e, [&](int edge) { return coplanar_edge[edge] != 0; })) continue;
      star[find_root(parent, *T.faces_of(v).first)] = 1;
    }
  // The anchor of a qualifying patch: its largest face.
  std::vector<int> largest(nf, -1);
  for (int f = 0; f < nf; ++f) {
    const int r = find_root(parent, f);
    const bool qualifies =
        size[r] >= 2 && (star[r] || !smooth_border[r] || smallest[r] >= opt.area_ratio * largest_border[r]);
    if (qualifies && (largest[r] < 0 || area[f] > area[largest[r]])) largest[r] = f;
  }
  for (int f = 0; f < nf; ++f) anchor[f] = largest[find_root(parent, f)];
  return anchor;
}

PlanarPatchResult flatten_planar_patches(const Mesh& mesh, const Topology& T, HighOrderMesh& hm,
                                         const PlanarPatchOptions& opt, const std::vector<char>* edge_feature) {
  if (hm.order < 2) return {};
  return flatten_planar_patches(mesh, T, hm, planar_patch_faces(mesh, T, opt, edge_feature));
}

PlanarPatchResult flatten_planar_patches(const Mesh& mesh, const Topology& T, HighOrderMesh& hm,
                                         const std::vector<int>& anchor) {
  PlanarPatchResult R;
  if (hm.order < 2) return R;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    R.faces += anchor[f] >= 0;
    R.patches += anchor[f] == f;
  }
  if (!R.faces) return R;
  // Onto the least-squares plane of the patch's corners (all its faces agree to coplanar_angle):
  // one face's plane, from float32 corners, tilts by their rounding over its size, which a long
  // chamfer strip carries to its far end (4e-7 where the input is 4e-8 off).
  std::vector<int> patch(mesh.num_faces(), -1);  // per anchor face: its patch's number
  int np = 0;
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (anchor[f] == f) patch[f] = np++;
  std::vector<Eigen::Vector3d> centre(np, Eigen::Vector3d::Zero()), normal(np);
  std::vector<Eigen::Matrix3d> second(np, Eigen::Matrix3d::Zero());
  std::vector<int> count(np, 0);
  for (int f = 0; f < mesh.num_faces(); ++f)
    if (anchor[f] >= 0)
      for (int j = 0; j < 3; ++j) {  // relative to the anchor's first corner: no cancellation
        const int i = patch[anchor[f]];
        const Eigen::Vector3d x = mesh.V.row(mesh.F(f, j)).transpose() - mesh.V.row(mesh.F(anchor[f], 0)).transpose();
        centre[i] += x;
        second[i] += x * x.transpose();
        ++count[i];
      }
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (anchor[f] != f) continue;
    const int i = patch[f];
    centre[i] /= count[i];
    const Eigen::Matrix3d cov = second[i] / count[i] - centre[i] * centre[i].transpose();
    normal[i] = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0);
    centre[i] += mesh.V.row(mesh.F(f, 0)).transpose();
  }
  auto project = [&](Eigen::MatrixXd& X, Eigen::Index row, int f) {
    const Eigen::Vector3d &n = normal[patch[anchor[f]]], &o = centre[patch[anchor[f]]];
    const double d = n.dot(X.row(row).transpose() - o);
    X.row(row) -= d * n.transpose();
    R.max_move = std::max(R.max_move, std::abs(d));
  };
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  std::vector<char> edge_done(T.num_edges(), 0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (anchor[f] < 0) continue;
    for (int j = 0; j < 3; ++j) {
      const int e = T.FE(f, j);
      if (edge_done[e]) continue;
      edge_done[e] = 1;
      for (int k = 0; k < npe; ++k) project(hm.edge_nodes, static_cast<Eigen::Index>(e) * npe + k, f);
    }
    for (int k = 0; k < npf; ++k) project(hm.face_nodes, static_cast<Eigen::Index>(f) * npf + k, f);
  }
  return R;
}

}  // namespace hocurve
