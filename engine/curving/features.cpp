#include "engine/curving/features.hpp"

#include "engine/core/error.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace hocurve {

namespace {

/// Unnormalised normal of face f (as oriented in the input).
Eigen::Vector3d face_normal(const Mesh& mesh, int f) {
  const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  return (b - a).cross(c - a);
}

/// Angle in degrees between u and v (0 when either is zero).
double angle_deg(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  const double nu = u.norm(), nv = v.norm();
  if (nu == 0 || nv == 0) return 0.0;
  // atan2 of |u x v| and u.v is accurate for small angles too, unlike acos.
  return std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / std::numbers::pi;
}

}  // namespace

Features detect_features(const Mesh& mesh, const Topology& T, const FeatureOptions& opt) {
  if (!(opt.angle_deg >= 0 && opt.angle_deg <= 180))
    throw InputError("features", "angle_deg must be in [0,180], got " + std::to_string(opt.angle_deg));
  if (!(opt.corner_angle_deg >= 0 && opt.corner_angle_deg <= 180))
    throw InputError("features", "corner_angle_deg must be in [0,180], got " + std::to_string(opt.corner_angle_deg));
  const int nv = mesh.num_vertices(), ne = T.num_edges();
  if (T.FE.rows() != mesh.num_faces() || static_cast<int>(T.ve_start.size()) != nv + 1)
    throw InputError("features", "topology was built for another mesh");
  Features R;
  R.edge_feature.assign(ne, 0);
  R.vertex_feature.assign(nv, 0);
  R.vertex_corner.assign(nv, 0);
  R.edge_curve.assign(ne, -1);

  // --- 1. feature edges ---------------------------------------------------------------------
  std::vector<char> only_sharp(ne, 0);  // feature only because of its dihedral angle
  for (int e = 0; e < ne; ++e) {
    const auto& ef = T.edge_faces[e];
    bool feat = false;
    if (ef.size() == 1) {
      ++R.boundary_edges, feat = true;
    } else if (ef.size() > 2) {
      ++R.nonmanifold_edges, feat = true;
    } else if (ef.size() == 2) {
      if (mesh.entity_of(ef[0]) != mesh.entity_of(ef[1])) {
        ++R.entity_border_edges;
        if (opt.entity_borders) feat = true;
      }
      const Eigen::Vector3d n0 = face_normal(mesh, ef[0]), n1 = face_normal(mesh, ef[1]);
      if (angle_deg(n0, n1) > opt.angle_deg) {
        ++R.sharp_edges;
        only_sharp[e] = !feat;
        feat = true;
      }
    }
    if (feat) {
      R.edge_feature[e] = 1;
      ++R.feature_edges;
    }
  }

  auto feature_edges_of = [&](int v, int* out) {  // fills up to 2, returns the valence
    int k = 0;
    auto [b, e] = T.edges_of(v);
    for (const int* it = b; it != e; ++it)
      if (R.edge_feature[*it]) {
        if (k < 2) out[k] = *it;
        ++k;
      }
    return k;
  };
  // Steps 2-3 run again after pruning, from the current edge marks.
  auto chain_all = [&] {
    R.vertex_feature.assign(nv, 0);
    R.vertex_corner.assign(nv, 0);
    R.edge_curve.assign(ne, -1);
    R.curves.clear();
    R.corners = 0;
    R.closed_curves = 0;
    // --- 2. corners: curves meet or end (feature valence != 2) or turn sharply ----------------
    for (int e = 0; e < ne; ++e)
      if (R.edge_feature[e]) R.vertex_feature[T.E(e, 0)] = R.vertex_feature[T.E(e, 1)] = 1;
    for (int v = 0; v < nv; ++v) {
      if (!R.vertex_feature[v]) continue;
      int fe[2];
      const int val = feature_edges_of(v, fe);
      bool corner = val != 2;
      if (!corner) {
        const int a = T.other(fe[0], v), b = T.other(fe[1], v);
        const Eigen::Vector3d din = mesh.V.row(v) - mesh.V.row(a), dout = mesh.V.row(b) - mesh.V.row(v);
        corner = angle_deg(din, dout) > opt.corner_angle_deg;
      }
      if (corner) R.vertex_corner[v] = 1, ++R.corners;
    }

    // --- 3. chain feature edges into curves ---------------------------------------------------
    // Walks from vertex `v` along feature edge `e` until a corner or back to the start.
    auto walk = [&](int v, int e) {
      const int id = static_cast<int>(R.curves.size());
      std::vector<int> chain{v};
      const int start = v;
      for (;;) {
        R.edge_curve[e] = id;
        v = T.other(e, v);
        chain.push_back(v);
        if (R.vertex_corner[v] || v == start) break;
        int fe[2];
        feature_edges_of(v, fe);  // valence 2 here: not a corner
        const int next = (fe[0] == e) ? fe[1] : fe[0];
        if (R.edge_curve[next] != -1) break;  // defensive: never loop forever
        e = next;
      }
      R.curves.push_back(std::move(chain));
    };
    for (int v = 0; v < nv; ++v) {
      if (!R.vertex_corner[v]) continue;
      auto [b, e] = T.edges_of(v);
      for (const int* it = b; it != e; ++it)
        if (R.edge_feature[*it] && R.edge_curve[*it] == -1) walk(v, *it);
    }
    // What is left are closed loops without corners; start each at its lowest-index edge.
    for (int e = 0; e < ne; ++e)
      if (R.edge_feature[e] && R.edge_curve[e] == -1) {
        walk(T.E(e, 0), e);
        ++R.closed_curves;
      }
  };
  chain_all();

  // --- 4. optional pruning of short dangling sharp curves (scan noise) -------------------------
  for (int pass = 0; pass < 8 && opt.min_dangling_edges > 0; ++pass) {
    long long pruned = 0;
    for (const auto& c : R.curves) {
      if (c.front() == c.back() || static_cast<int>(c.size()) - 1 >= opt.min_dangling_edges) continue;
      int fe[2];
      const bool free_end = feature_edges_of(c.front(), fe) == 1 || feature_edges_of(c.back(), fe) == 1;
      if (!free_end) continue;
      bool sharp_only = true;
      for (size_t i = 0; i + 1 < c.size(); ++i) {
        // the edge between c[i] and c[i+1]
        auto [b, e] = T.edges_of(c[i]);
        for (const int* it = b; it != e; ++it)
          if (T.other(*it, c[i]) == c[i + 1]) sharp_only = sharp_only && only_sharp[*it];
      }
      if (!sharp_only) continue;
      for (size_t i = 0; i + 1 < c.size(); ++i) {
        auto [b, e] = T.edges_of(c[i]);
        for (const int* it = b; it != e; ++it)
          if (T.other(*it, c[i]) == c[i + 1] && R.edge_feature[*it]) R.edge_feature[*it] = 0, ++pruned;
      }
    }
    if (pruned == 0) break;
    R.pruned_edges += pruned;
    R.feature_edges -= pruned;
    chain_all();
  }
  return R;
}

}  // namespace hocurve
