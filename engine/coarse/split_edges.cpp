#include "engine/coarse/split_edges.hpp"

#include "engine/core/error.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace hocurve {

namespace {

Eigen::Vector3d corner(const Mesh& m, int f, int j) { return m.V.row(m.F(f, j)).transpose(); }

Eigen::Vector3d unit_normal(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return (b - a).cross(c - a).normalized();
}

int local_index(const Mesh& m, int f, int v) {
  for (int j = 0; j < 3; ++j)
    if (m.F(f, j) == v) return j;
  return -1;
}

/// Barycentrics on the part of a face -> barycentrics on the face: the part keeps the face's
/// corners but corner `moved`, which becomes the point t corner i + (1 - t) corner j.
Eigen::Matrix3d part_to_face(int moved, int i, int j, double t) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S.col(moved).setZero();
  S(i, moved) = t;
  S(j, moved) = 1 - t;
  return S;
}

/// Whether both parts of face f (corner a, then corner b, moved to m) keep their orientation and
/// shape.
bool parts_ok(const Mesh& C, int f, int a, int b, const Eigen::Vector3d& m, double cos_fold, double cos_sliver) {
  const Eigen::Vector3d p[3] = {corner(C, f, 0), corner(C, f, 1), corner(C, f, 2)};
  const Eigen::Vector3d n = unit_normal(p[0], p[1], p[2]);
  // Half the face's smallest angle, as a cosine: cos(x/2) = sqrt((1 + cos x) / 2).
  const double cos_half_old = std::sqrt(0.5 * (1 + min_angle_cos_max(p[0], p[1], p[2])));
  for (int v : {a, b}) {
    Eigen::Vector3d q[3] = {p[0], p[1], p[2]};
    q[local_index(C, f, v)] = m;
    const Eigen::Vector3d nq = unit_normal(q[0], q[1], q[2]);
    const double cmin = min_angle_cos_max(q[0], q[1], q[2]);
    if (!nq.allFinite() || nq.dot(n) < cos_fold || (cmin > cos_sliver && cmin > cos_half_old)) return false;
  }
  return true;
}

}  // namespace

SplitResult split_coarse_edges(DecimateResult& dec, const std::vector<std::array<int, 2>>& edges,
                               const SplitOptions& opt) {
  Mesh& C = dec.coarse;
  CoarseMap& M = dec.map;
  if (M.cf_start.size() != static_cast<size_t>(C.num_faces()) + 1)
    throw UsageError("split_coarse_edges: the decimation result carries no map");
  SplitResult R;
  const long long nv0 = C.num_vertices();
  std::unordered_map<long long, int> face_of;  // directed edge (a, b) -> face, of the faces before this call
  for (int f = 0; f < C.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) face_of[C.F(f, j) * nv0 + C.F(f, (j + 1) % 3)] = f;
  if (M.split_to_base.empty()) {
    M.split_to_base.assign(C.num_faces(), Eigen::Matrix3d::Identity());
    M.split_next.assign(C.num_faces(), -1);
  }
  const double cos_fold = std::cos(opt.max_normal_change_deg * std::numbers::pi / 180);
  const double cos_sliver = std::cos(opt.min_angle_deg * std::numbers::pi / 180);
  std::vector<char> used(C.num_faces(), 0);  // split in this call: its edges are gone

  auto try_split = [&](int a, int b) {
    if (a == b || a < 0 || b < 0 || a >= nv0 || b >= nv0) return false;
    // The faces on either side: one on the open boundary.
    std::vector<int> faces;
    for (const long long key : {a * nv0 + b, b * nv0 + a})
      if (const auto it = face_of.find(key); it != face_of.end()) faces.push_back(it->second);
    if (faces.empty()) return false;
    for (int f : faces)
      if (used[f]) return false;
    // The midpoint of a b in the parametrization, on the dense surface; where its parts would
    // fold (the dense surface dips between a and b), points nearer a or b.
    double t = 0;
    Eigen::Vector3d m;
    bool ok = false;
    for (double s : {0.5, 0.4, 0.6, 0.3, 0.7}) {
      Eigen::Vector3d xi = Eigen::Vector3d::Zero();
      xi[local_index(C, faces[0], a)] = s;
      xi[local_index(C, faces[0], b)] = 1 - s;
      m = coarse_to_fine(M, faces[0], xi).position;
      t = s;
      ok = std::all_of(faces.begin(), faces.end(), [&](int f) { return parts_ok(C, f, a, b, m, cos_fold, cos_sliver); });
      if (ok) break;
    }
    if (!ok) return false;
    const int vm = C.num_vertices();
    C.V.conservativeResize(vm + 1, 3);
    C.V.row(vm) = m.transpose();
    dec.coarse_vertex_origin.push_back(-1);
    dec.coarse_vertex_feature.push_back(0);
    dec.coarse_vertex_pinned.push_back(0);
    for (int f : faces) {
      const int ia = local_index(C, f, a), ib = local_index(C, f, b);
      // f keeps the part without b, the new face g the part without a.
      const int g = C.num_faces();
      C.F.conservativeResize(g + 1, 3);
      C.F.row(g) = C.F.row(f);
      C.F(f, ib) = vm;
      C.F(g, ia) = vm;
      if (C.face_entity.size()) {
        C.face_entity.conservativeResize(g + 1);
        C.face_entity[g] = C.face_entity[f];
      }
      const Eigen::Matrix3d Sf = part_to_face(ib, ia, ib, t), Sg = part_to_face(ia, ia, ib, t);
      const Eigen::Matrix3d Sf_inv = Sf.inverse(), Sg_inv = Sg.inverse();
      // The fine vertices of f go to the part that holds them (f's list is still the one from
      // before this call: no earlier split in it touched f).
      auto [vb, ve] = M.fine_vertices_in(f);
      for (const int* v = vb; v != ve; ++v) {
        const Eigen::Vector3d beta = M.vertex_coarse_bary.row(*v).transpose();
        const Eigen::Vector3d lf = Sf_inv * beta, lg = Sg_inv * beta;
        const bool to_g = lg.minCoeff() > lf.minCoeff();
        const Eigen::Vector3d l = (to_g ? lg : lf).cwiseMax(0.0);
        M.vertex_coarse_face[*v] = to_g ? g : f;
        M.vertex_coarse_bary.row(*v) = (l / l.sum()).transpose();
      }
      M.coarse_face_id.push_back(M.coarse_face_id[f]);
      M.split_to_base.push_back(M.split_to_base[f] * Sg);
      M.split_to_base[f] = M.split_to_base[f] * Sf;
      M.split_next.push_back(M.split_next[f]);
      M.split_next[f] = g;
      used.push_back(1);
      used[f] = 1;
      R.faces.push_back(f);
    }
    R.vertices.push_back({a, b, vm});
    return true;
  };

  for (const auto& [a, b] : edges) ++(try_split(a, b) ? R.split : R.refused);
  M.coarse_V = C.V;
  M.coarse_F = C.F;
  index_fine_vertices(M);
  return R;
}

}  // namespace hocurve
