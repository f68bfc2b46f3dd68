#include "engine/coarse/decimate.hpp"

#include "engine/coarse/dense_surface.hpp"
#include "engine/coarse/face_bound.hpp"
#include "engine/coarse/flatten.hpp"
#include "engine/coarse/quadric.hpp"
#include "engine/coarse/surface_distance.hpp"
#include "engine/coarse/vertex_fans.hpp"
#include "engine/core/error.hpp"
#include "engine/core/stopwatch.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <queue>
#include <string>
#include <unordered_set>

namespace hocurve {

namespace {

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

/// Feature marks the decimation respects. Boundary edges are always features (they collapse only
/// along the boundary); sharp edges and entity borders only when preserve_features.
struct FeatureMarks {
  std::vector<char> edge;    ///< per topology edge
  std::vector<char> vertex;  ///< on a feature edge
  std::vector<char> corner;  ///< never removed
};

/// Feature marks from curving/features.hpp's detect_features; without feature preservation
/// only the open boundary is marked.
FeatureMarks mark_features(const Mesh& m, const Topology& T, const DecimateOptions& opt) {
  const int nv = m.num_vertices();
  FeatureMarks fm;
  if (opt.preserve_features) {
    FeatureOptions fo;
    fo.angle_deg = opt.feature_angle_deg;
    fo.corner_angle_deg = opt.corner_angle_deg;
    fo.entity_borders = opt.entity_borders;
    fo.fillet_max_deg = 0;  // as feature_options() (lift.cpp) says why
    fo.min_dangling_edges = 0;  // short curves are dropped below, by this decimation's own rules
    Features f = detect_features(m, T, fo);
    fm.edge = std::move(f.edge_feature);
    fm.corner = std::move(f.vertex_corner);
    // Drop short open curves made only of sharp edges (boundaries and entity borders stay);
    // soft ones (mean dihedral below soft_feature_angle_deg: the creases of scans and organic
    // meshes, not machined edges) up to min_soft_curve_edges, since they pin the decimation.
    std::vector<double> angle_sum(f.curves.size(), 0);
    for (int e = 0; e < T.num_edges(); ++e) {
      const int c = f.edge_curve[e];
      const auto& ef = T.edge_faces[e];
      if (c < 0 || ef.size() != 2) continue;
      Eigen::Vector3d n[2];
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector3d a = m.V.row(m.F(ef[k], 0)), b = m.V.row(m.F(ef[k], 1)), d = m.V.row(m.F(ef[k], 2));
        n[k] = (b - a).cross(d - a);
      }
      angle_sum[c] += std::atan2(n[0].cross(n[1]).norm(), n[0].dot(n[1]));
    }
    std::vector<char> drop(f.curves.size(), 0);
    for (size_t c = 0; c < f.curves.size(); ++c) {
      const auto& cv = f.curves[c];
      const int edges = static_cast<int>(cv.size()) - 1;
      if (cv.size() < 2 || cv.front() == cv.back()) continue;
      const bool soft = angle_sum[c] / edges < opt.soft_feature_angle_deg * std::numbers::pi / 180;
      drop[c] = edges < (soft ? opt.min_soft_curve_edges : opt.min_feature_curve_edges);
    }
    for (int e = 0; e < T.num_edges(); ++e) {
      const int c = f.edge_curve[e];
      const auto& ef = T.edge_faces[e];
      if (c >= 0 && drop[c] && ef.size() == 2 && m.entity_of(ef[0]) == m.entity_of(ef[1])) fm.edge[e] = 0;
    }
    // Vertex flags from what is left; a vertex where the curves now end is a corner.
    fm.vertex.assign(nv, 0);
    std::vector<int> valence(nv, 0);
    for (int e = 0; e < T.num_edges(); ++e)
      if (fm.edge[e])
        for (int j = 0; j < 2; ++j) fm.vertex[T.E(e, j)] = 1, ++valence[T.E(e, j)];
    for (int v = 0; v < nv; ++v) fm.corner[v] = fm.vertex[v] && (fm.corner[v] || valence[v] != 2);
    return fm;
  }
  fm.edge.assign(T.num_edges(), 0);
  fm.vertex.assign(nv, 0);
  fm.corner.assign(nv, 0);
  std::vector<int> valence(nv, 0);
  for (int e = 0; e < T.num_edges(); ++e)
    if (T.edge_faces[e].size() == 1) {
      fm.edge[e] = 1;
      for (int j = 0; j < 2; ++j) fm.vertex[T.E(e, j)] = 1, ++valence[T.E(e, j)];
    }
  // A vertex where boundary loops touch (valence != 2) must stay.
  for (int v = 0; v < nv; ++v) fm.corner[v] = fm.vertex[v] && valence[v] != 2;
  return fm;
}

/// Refuses input the collapse machinery cannot keep manifold: repeated corners, edges with more
/// than two faces, inconsistent orientation, vertices whose faces form several fans.
void check_manifold(const Mesh& m, const Topology& T) {
  const std::string where = "decimate";
  for (int f = 0; f < m.num_faces(); ++f) {
    for (int j = 0; j < 3; ++j)
      if (m.F(f, j) < 0 || m.F(f, j) >= m.num_vertices())
        throw InputError(where, "face " + std::to_string(f) + " references vertex " + std::to_string(m.F(f, j)) +
                                    " out of range");
    if (m.F(f, 0) == m.F(f, 1) || m.F(f, 1) == m.F(f, 2) || m.F(f, 0) == m.F(f, 2))
      throw InputError(where, "face " + std::to_string(f) + " repeats a vertex");
  }
  for (int e = 0; e < T.num_edges(); ++e) {
    const auto& ef = T.edge_faces[e];
    const std::string name = "edge (" + std::to_string(T.E(e, 0)) + "," + std::to_string(T.E(e, 1)) + ")";
    if (ef.size() > 2)
      throw InputError(where, name + " is shared by " + std::to_string(ef.size()) + " faces: non-manifold");
    if (ef.size() == 2) {
      auto dir = [&](int f) {  // +1 if f uses the edge as E0 -> E1
        for (int j = 0; j < 3; ++j)
          if (m.F(f, j) == T.E(e, 0) && m.F(f, (j + 1) % 3) == T.E(e, 1)) return 1;
        return -1;
      };
      if (dir(ef[0]) == dir(ef[1]))
        throw InputError(where, name + ": faces " + std::to_string(ef[0]) + " and " + std::to_string(ef[1]) +
                                    " have inconsistent orientation: the surface is not orientable (as a Moebius "
                                    "band) or was not oriented (validate_mesh orients every orientable component); "
                                    "coarsening needs one consistent side");
    }
  }
  // Vertex manifoldness: the faces around v, linked through shared edges, form one fan.
  std::vector<int> fan;
  for (int v = 0; v < m.num_vertices(); ++v)
    if (vertex_fans(m, T, v, fan) > 1)
      throw InputError(where, "vertex " + std::to_string(v) +
                                  " joins several fans of faces: non-manifold (split_vertex_fans() gives each fan its own copy)");
}

struct Entry {
  double cost;
  int a, b;
  unsigned va, vb;
  bool deferred = false;  ///< re-queued for moving its dense points too far: after every other entry
  bool operator>(const Entry& o) const {
    if (deferred != o.deferred) return deferred;
    if (cost != o.cost) return cost > o.cost;
    if (a != o.a) return a > o.a;
    return b > o.b;
  }
};

enum class Reason { ok, link, feature, boundary, valence, fold, sliver, flatten, deviation, deferred };

struct Plan {
  Reason reason = Reason::ok;
  int s = -1, r = -1;
  Eigen::Vector3d p;
  double cost = 0;
  bool snapped = false;  ///< p is the survivor's own position
};

/// The working mesh: simple vertex -> faces adjacency, faces keep their ids while alive.
struct Decimator {
  const DecimateOptions& opt;
  std::vector<Eigen::Vector3d> X;
  std::vector<std::array<int, 3>> F;
  std::vector<char> face_alive, v_alive, vfeat, vcorner, vbnd, vpinned;
  std::vector<std::vector<int>> vf;
  std::vector<unsigned> ver;
  std::vector<Quadric> Q;
  std::unordered_set<std::uint64_t> feat, rejected;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  int faces_alive = 0;
  double cos_fold = 0, cos_min_angle = 0;
  /// Collapses that would leave a tracked dense vertex (positions dense_V) further than this from
  /// the straight coarse surface are deferred (0: never).
  double defer_distance = 0;
  double max_distance = 0;  ///< ... refused beyond this (0: never)
  const Eigen::MatrixXd* dense_V = nullptr;
  TriangleGrid dense_grid;  ///< the input's triangles, for the coarse -> dense side of max_distance

  // tracking of fine vertices
  bool track = false;
  std::vector<std::vector<int>> face_pts;
  std::vector<int> pt_face;
  std::vector<Eigen::Vector3d> pt_bary;

  CoarseMap* map = nullptr;
  RejectCounts* rej = nullptr;
  double t_flatten = 0, t_track = 0;

  explicit Decimator(const DecimateOptions& o) : opt(o) {}

  void neighbors(int v, std::vector<int>& out) const {
    out.clear();
    for (int f : vf[v])
      for (int x : F[f])
        if (x != v && std::find(out.begin(), out.end(), x) == out.end()) out.push_back(x);
  }
  Plan plan(int a, int b) const {
    Plan P;
    Quadric q = Q[a];
    q += Q[b];
    const double len2 = (X[a] - X[b]).squaredNorm();
    const double tie = 1e-6 * q.trace() * len2;  // shortest edge first where Q vanishes (flat parts)
    auto snapped = [&](int s, int r) {
      P.s = s, P.r = r, P.p = X[s], P.snapped = true;
      P.cost = q.eval(P.p) + tie;
    };
    const bool fa = vfeat[a], fb = vfeat[b], ca = vcorner[a], cb = vcorner[b];
    const bool ef = feat.count(edge_key(a, b)) > 0;
    if (ef) {  // along a feature curve or the open boundary: the survivor stays on it
      if (ca && cb) P.reason = Reason::feature;
      if (ca) snapped(a, b);
      else if (cb) snapped(b, a);
      else {
        const double qa = q.eval(X[a]), qb = q.eval(X[b]);
        if (qa < qb || (qa == qb && a < b)) snapped(a, b);
        else snapped(b, a);
      }
      return P;
    }
    if (fa && fb) {
      P.reason = Reason::feature;
      snapped(a, b);
      return P;
    }
    if (fa) return snapped(a, b), P;
    if (fb) return snapped(b, a), P;
    P.s = std::min(a, b), P.r = std::max(a, b);
    const Eigen::Vector3d mid = 0.5 * (X[a] + X[b]);
    const double lambda = 1e-3 * q.trace() + 1e-300;
    P.p = quadric_minimiser(q, mid, lambda);
    P.cost = q.eval(P.p) + lambda * (P.p - mid).squaredNorm() + tie;
    return P;
  }

  void push(int a, int b) {
    rejected.erase(edge_key(a, b));
    const Plan P = plan(a, b);
    heap.push({P.cost, std::min(a, b), std::max(a, b), ver[std::min(a, b)], ver[std::max(a, b)]});
  }

  /// Performs the collapse of P unless a check refuses it. may_defer: a collapse moving the dense
  /// surface further than defer_distance returns Reason::deferred with that distance in deviation.
  Reason check_and_collapse(const Plan& P, bool may_defer, double& deviation);
};

Reason Decimator::check_and_collapse(const Plan& P, bool may_defer, double& deviation) {
  const int s = P.s, r = P.r;
  // Patch: faces around s or r.
  std::vector<int> pf = vf[s];
  for (int f : vf[r])
    if (std::find(pf.begin(), pf.end(), f) == pf.end()) pf.push_back(f);
  std::vector<int> edge_faces, wings;
  for (int f : vf[s])
    for (int x : F[f])
      if (x == r) edge_faces.push_back(f);
  // An edge of the open boundary has one face (plan() lets only boundary edges of the boundary
  // curve through: both ends are boundary vertices).
  const int ne = static_cast<int>(edge_faces.size());
  if (ne != 2 && !(ne == 1 && vbnd[s] && vbnd[r])) return Reason::boundary;
  for (int f : edge_faces)
    for (int x : F[f])
      if (x != s && x != r) wings.push_back(x);
  if (ne == 2 && wings[0] == wings[1]) return Reason::link;
  // Link condition: the only common neighbours are the wing vertices.
  std::vector<int> ns, nr;
  neighbors(s, ns);
  neighbors(r, nr);
  int common = 0;
  for (int x : ns)
    if (std::find(nr.begin(), nr.end(), x) != nr.end()) ++common;
  if (common != ne) return Reason::link;
  // No new edge at a pinned vertex (a copy at a split point, rejoined afterwards): the link
  // condition sees one copy, and the new edge may duplicate an edge of another copy (a raw Thingi10K
  // file, pinched where faces overlap, came out with an edge of four faces after one collapse).
  for (int x : nr)
    if (x != s && (vpinned[s] || vpinned[x]) && std::find(ns.begin(), ns.end(), x) == ns.end()) return Reason::link;
  // Valence and size.
  const int new_deg = static_cast<int>(vf[s].size() + vf[r].size()) - 2 * ne;
  if (new_deg < (vbnd[s] ? 1 : 3)) return Reason::valence;
  for (int c : wings)
    if (static_cast<int>(vf[c].size()) - 1 < (vbnd[c] ? 1 : 3)) return Reason::valence;
  if (faces_alive - ne < 4 || pf.size() > 120 || ns.size() + nr.size() > 240) return Reason::valence;
  // Feature curves must not shrink into a two-edge loop.
  if (feat.count(edge_key(s, r)))
    for (int c : wings)
      if (feat.count(edge_key(s, c)) && feat.count(edge_key(r, c))) return Reason::feature;
  // 3D checks on the faces that survive: no fold-over, no sliver.
  double worst_old = -1;  // largest cos(min angle) of the pre patch
  for (int f : pf) worst_old = std::max(worst_old, min_angle_cos_max(X[F[f][0]], X[F[f][1]], X[F[f][2]]));
  for (int f : pf) {
    const auto& t = F[f];
    if (t[0] == r || t[1] == r || t[2] == r)
      if (t[0] == s || t[1] == s || t[2] == s) continue;
    Eigen::Vector3d xo[3], xn[3];
    for (int j = 0; j < 3; ++j) {
      xo[j] = X[t[j]];
      xn[j] = (t[j] == s || t[j] == r) ? P.p : X[t[j]];
    }
    const Eigen::Vector3d no = (xo[1] - xo[0]).cross(xo[2] - xo[0]);
    const Eigen::Vector3d nn = (xn[1] - xn[0]).cross(xn[2] - xn[0]);
    const double lno = no.norm(), lnn = nn.norm();
    const double scale = (xn[1] - xn[0]).squaredNorm() + (xn[2] - xn[0]).squaredNorm() + (xn[2] - xn[1]).squaredNorm();
    if (!(lnn > 1e-12 * scale)) return Reason::sliver;
    // A zero-area face (a cap closing a T-junction) has no normal to fold away from.
    const double scale_old = (xo[1] - xo[0]).squaredNorm() + (xo[2] - xo[0]).squaredNorm() + (xo[2] - xo[1]).squaredNorm();
    if (lno > kZeroArea * scale_old && no.dot(nn) < cos_fold * lno * lnn) return Reason::fold;
    const double cmin = min_angle_cos_max(xn[0], xn[1], xn[2]);
    if (cmin > cos_min_angle && cmin > worst_old) return Reason::sliver;
  }

  // Joint flattening and record.
  std::vector<int> loc{s, r};
  CollapsePatch patch;
  PatchFlattening flat;
  if (track || map) {
    const auto t0 = Clock::now();
    auto local = [&](int v) {
      for (size_t i = 0; i < loc.size(); ++i)
        if (loc[i] == v) return static_cast<int>(i);
      loc.push_back(v);
      return static_cast<int>(loc.size() - 1);
    };
    for (int f : pf) {
      std::array<int, 3> t{local(F[f][0]), local(F[f][1]), local(F[f][2])};
      patch.faces.push_back(t);
      patch.removed.push_back(std::find(edge_faces.begin(), edge_faces.end(), f) != edge_faces.end());
    }
    for (int v : loc) patch.X.push_back(X[v]);
    patch.p = P.p;
    patch.post_reuses_survivor_uv = P.snapped;
    if (feat.count(edge_key(s, r)))
      for (int x : nr)
        if (x != s && feat.count(edge_key(r, x))) patch.curve_pin = local(x);  // already local: a neighbour of r
    patch.s_interior = !vbnd[s];
    patch.r_interior = !vbnd[r];
    FlattenOptions fo;
    fo.min_quality = opt.uv_min_quality;
    flat = flatten_collapse(patch, fo);
    t_flatten += seconds_since(t0);
    if (!flat.ok) return Reason::flatten;
  }
  // Where the tracked dense vertices land: (vertex, post-collapse triangle, barycentrics).
  struct Landing { int pt, tri; Eigen::Vector3d bary; };
  std::vector<Landing> landings;
  std::vector<std::array<int, 3>> post_tris;
  std::vector<int> post_ids;
  if (track) {
    const auto t0 = Clock::now();
    for (size_t k = 0; k < pf.size(); ++k)
      if (!patch.removed[k]) post_tris.push_back(post_triangle(patch, static_cast<int>(k))), post_ids.push_back(pf[k]);
    for (size_t k = 0; k < pf.size(); ++k)
      for (int pt : face_pts[pf[k]]) {
        const auto& t = patch.faces[k];
        const Eigen::Vector3d& b = pt_bary[pt];
        const Eigen::Vector2d q = b[0] * flat.uv[t[0]] + b[1] * flat.uv[t[1]] + b[2] * flat.uv[t[2]];
        Landing L{pt, 0, Eigen::Vector3d::Zero()};
        L.tri = locate_uv(flat.uv.data(), post_tris.data(), static_cast<int>(post_tris.size()), q, L.bary, nullptr);
        landings.push_back(L);
      }
    t_track += seconds_since(t0);
  }
  // Their largest distance from the straight faces after the collapse: to their landing points for
  // the deferral; to the new faces for max_distance (the map's tangential slide, across flat
  // regions or over feature curves, is no deviation of the surface).
  bool too_far = false;
  if (track && ((may_defer && defer_distance > 0) || max_distance > 0)) {
    const int post = patch.post_reuses_survivor_uv ? 0 : static_cast<int>(patch.X.size());
    auto corner = [&](int t, int j) -> const Eigen::Vector3d& {
      const int l = post_tris[t][j];
      return l == post ? P.p : patch.X[l];
    };
    double dev = 0;
    Eigen::Vector3d bary;
    for (const Landing& L : landings) {
      const Eigen::Vector3d q = dense_V->row(L.pt).transpose();
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) x += L.bary[j] * corner(L.tri, j);
      const double d = (x - q).norm();
      dev = std::max(dev, d);
      if (max_distance > 0 && d > max_distance && !too_far) {  // the landing point bounds the distance
        double dmin = std::numeric_limits<double>::infinity();
        for (size_t t = 0; t < post_tris.size(); ++t)
          dmin = std::min(dmin, (closest_point_on_triangle(q, corner(t, 0), corner(t, 1), corner(t, 2), bary) - q).norm());
        too_far = dmin > max_distance;
      }
    }
    // ... and the other way: the new vertex, the midpoints of its edges and the new faces' centroids
    // must stay near the input (the other vertices and edges were checked when they were made).
    if (max_distance > 0 && !too_far) too_far = !grid_within(dense_grid, P.p, max_distance);
    for (size_t t = 0; t < post_tris.size() && max_distance > 0 && !too_far; ++t)
      for (int j = 0; j < 3 && !too_far; ++j) {
        if (post_tris[t][j] != post) continue;
        const Eigen::Vector3d &a = corner(t, (j + 1) % 3), &b = corner(t, (j + 2) % 3);
        too_far = !grid_within(dense_grid, 0.5 * (P.p + a), max_distance) ||
                  !grid_within(dense_grid, (P.p + a + b) / 3, max_distance);
      }
    deviation = dev;
    if (too_far) return Reason::deviation;
    if (may_defer && defer_distance > 0 && dev > defer_distance) return Reason::deferred;
  }

  // --- accepted: record, move tracked points, update connectivity ---
  if (map) {
    map->rec_uv.insert(map->rec_uv.end(), flat.uv.begin(), flat.uv.end());
    map->rec_uv_start.push_back(static_cast<int>(map->rec_uv.size()));
    for (size_t k = 0; k < pf.size(); ++k) {
      map->rec_face.push_back(pf[k]);
      const auto& t = patch.faces[k];
      map->rec_face_local.push_back({static_cast<std::uint8_t>(t[0]), static_cast<std::uint8_t>(t[1]),
                                     static_cast<std::uint8_t>(t[2])});
      map->rec_face_removed.push_back(patch.removed[k]);
    }
    map->rec_face_start.push_back(static_cast<int>(map->rec_face.size()));
    map->rec_post_reuses.push_back(patch.post_reuses_survivor_uv);
    map->rec_edge.push_back({s, r});
  }
  if (track) {
    for (size_t k = 0; k < pf.size(); ++k) face_pts[pf[k]].clear();
    for (const Landing& L : landings) {
      pt_face[L.pt] = post_ids[L.tri];
      pt_bary[L.pt] = L.bary;
      face_pts[pt_face[L.pt]].push_back(L.pt);
    }
  }
  // Feature edges of r move to s.
  for (int x : nr) {
    const auto key = edge_key(r, x);
    if (feat.erase(key) && x != s) feat.insert(edge_key(s, x));
  }
  for (int f : vf[r]) {
    auto& t = F[f];
    if (t[0] == s || t[1] == s || t[2] == s) {
      face_alive[f] = 0;
      --faces_alive;
      for (int x : t)
        if (x != r) vf[x].erase(std::find(vf[x].begin(), vf[x].end(), f));
    } else {
      for (int& x : t)
        if (x == r) x = s;
      vf[s].push_back(f);
    }
  }
  vf[r].clear();
  v_alive[r] = 0;
  X[s] = P.p;
  Q[s] += Q[r];
  ++ver[s];
  // New costs around s; edges refused near the change get another chance.
  neighbors(s, ns);
  for (int x : ns) push(s, x);
  std::vector<int> nx;
  for (int x : ns) {
    neighbors(x, nx);
    for (int y : nx)
      if (y != s && rejected.count(edge_key(x, y))) push(x, y);
  }
  return Reason::ok;
}

}  // namespace

double min_angle_cos_max(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  // Largest cosine among the three angles = cosine of the smallest angle.
  auto cosang = [](const Eigen::Vector3d& o, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
    const Eigen::Vector3d u = p - o, v = q - o;
    const double d = u.norm() * v.norm();
    return d > 0 ? u.dot(v) / d : 1.0;
  };
  return std::max({cosang(a, b, c), cosang(b, c, a), cosang(c, a, b)});
}

DecimateResult decimate(const Mesh& fine, const DecimateOptions& opt) {
  const auto t0 = Clock::now();
  DecimateResult R;
  const int nv = fine.num_vertices(), nf = fine.num_faces();
  // Fewer than 4 faces: no collapse is possible (a closed mesh needs 4); the result is the input.
  if (opt.target_faces <= 0 && !(opt.target_ratio > 0 && opt.target_ratio <= 1))
    throw UsageError("decimate: target_ratio must be in (0,1], got " + std::to_string(opt.target_ratio));
  R.target_faces = opt.target_faces > 0 ? opt.target_faces
                                        : std::max(4, static_cast<int>(std::lround(opt.target_ratio * nf)));
  const Topology T = build_topology(fine.F, nv);
  check_manifold(fine, T);
  FeatureMarks fm = mark_features(fine, T, opt);
  for (int v : opt.pinned_vertices) {
    if (v < 0 || v >= nv) throw UsageError("decimate: pinned vertex " + std::to_string(v) + " out of range");
    fm.vertex[v] = fm.corner[v] = 1;
  }

  Decimator D(opt);
  if (opt.build_map && (opt.defer_deviation > 0 || opt.max_deviation > 0)) {
    const double diag = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();
    D.defer_distance = opt.defer_deviation * diag;
    D.max_distance = opt.max_deviation * diag;
    D.dense_V = &fine.V;
    if (D.max_distance > 0) D.dense_grid = build_triangle_grid(fine);
  }
  D.cos_fold = std::cos(opt.max_normal_change_deg * std::numbers::pi / 180);
  D.cos_min_angle = std::cos(opt.min_angle_deg * std::numbers::pi / 180);
  D.X.resize(nv);
  for (int v = 0; v < nv; ++v) D.X[v] = fine.V.row(v).transpose();
  D.F.resize(nf);
  for (int f = 0; f < nf; ++f) D.F[f] = {fine.F(f, 0), fine.F(f, 1), fine.F(f, 2)};
  D.face_alive.assign(nf, 1);
  D.faces_alive = nf;
  D.v_alive.assign(nv, 1);
  D.vfeat = fm.vertex;
  D.vcorner = fm.corner;
  D.vpinned.assign(nv, 0);
  for (int v : opt.pinned_vertices) D.vpinned[v] = 1;
  D.vbnd.assign(nv, 0);
  D.ver.assign(nv, 0);
  D.vf.resize(nv);
  for (int f = 0; f < nf; ++f)
    for (int x : D.F[f]) D.vf[x].push_back(f);
  for (int e = 0; e < T.num_edges(); ++e) {
    if (T.edge_faces[e].size() == 1) D.vbnd[T.E(e, 0)] = D.vbnd[T.E(e, 1)] = 1;
    if (fm.edge[e]) D.feat.insert(edge_key(T.E(e, 0), T.E(e, 1))), ++R.feature_edges;
  }
  for (int v = 0; v < nv; ++v) R.corners += fm.corner[v];
  R.fewest_faces = fewest_faces_keeping(fine, T, fm.edge, fm.corner);
  if (!opt.vertex_weight.empty() && static_cast<int>(opt.vertex_weight.size()) != nv)
    throw UsageError("decimate: vertex_weight has " + std::to_string(opt.vertex_weight.size()) + " entries for " +
                     std::to_string(nv) + " vertices");
  auto weight = [&](int v) { return opt.vertex_weight.empty() ? 1.0 : opt.vertex_weight[v]; };
  // Quadrics: area-weighted face planes, plus planes through feature edges perpendicular to
  // their faces so that feature curves cost what they deviate; each scaled by its vertex's weight.
  D.Q.assign(nv, Quadric{});
  for (int f = 0; f < nf; ++f) {
    const auto& t = D.F[f];
    const Eigen::Vector3d n2 = (D.X[t[1]] - D.X[t[0]]).cross(D.X[t[2]] - D.X[t[0]]);
    const double area = 0.5 * n2.norm();
    if (!(area > 0)) continue;
    const Eigen::Vector3d n = n2.normalized();
    for (int x : t) D.Q[x] += plane_quadric(D.X[t[0]], n, area * weight(x));
    for (int j = 0; j < 3; ++j) {
      const int a = t[j], b = t[(j + 1) % 3];
      if (!D.feat.count(edge_key(a, b))) continue;
      const Eigen::Vector3d e = D.X[b] - D.X[a];
      const Eigen::Vector3d m = e.cross(n);
      if (m.norm() == 0) continue;
      D.Q[a] += plane_quadric(D.X[a], m.normalized(), e.squaredNorm() * weight(a));
      D.Q[b] += plane_quadric(D.X[a], m.normalized(), e.squaredNorm() * weight(b));
    }
  }
  D.rej = &R.rejected;
  if (opt.build_map) {
    D.map = &R.map;
    D.track = true;
    R.map.rec_uv_start.push_back(0);
    R.map.rec_face_start.push_back(0);
    D.face_pts.resize(nf);
    D.pt_face.resize(nv);
    D.pt_bary.resize(nv);
    for (int v = 0; v < nv; ++v) {
      const int f = D.vf[v].empty() ? -1 : D.vf[v][0];
      if (f < 0) throw InputError("decimate", "vertex " + std::to_string(v) + " is used by no face");
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j)
        if (D.F[f][j] == v) b[j] = 1;
      D.pt_face[v] = f;
      D.pt_bary[v] = b;
      D.face_pts[f].push_back(v);
    }
  } else {
    for (int v = 0; v < nv; ++v)
      if (D.vf[v].empty()) throw InputError("decimate", "vertex " + std::to_string(v) + " is used by no face");
  }
  for (int e = 0; e < T.num_edges(); ++e) D.push(T.E(e, 0), T.E(e, 1));

  while (D.faces_alive > R.target_faces && !D.heap.empty()) {
    const Entry en = D.heap.top();
    D.heap.pop();
    if (!D.v_alive[en.a] || !D.v_alive[en.b] || D.ver[en.a] != en.va || D.ver[en.b] != en.vb) continue;
    const Plan P = D.plan(en.a, en.b);
    Reason why = P.reason;
    double deviation = 0;
    if (why == Reason::ok) why = D.check_and_collapse(P, !en.deferred, deviation);
    switch (why) {
      case Reason::ok: ++R.collapses; continue;
      case Reason::deferred: {
        Entry later = en;
        later.deferred = true;
        later.cost = deviation;
        D.heap.push(later);
        ++R.deferred;
        continue;
      }
      case Reason::link: ++R.rejected.link; break;
      case Reason::feature: ++R.rejected.feature; break;
      case Reason::boundary: ++R.rejected.boundary; break;
      case Reason::valence: ++R.rejected.valence; break;
      case Reason::fold: ++R.rejected.fold; break;
      case Reason::sliver: ++R.rejected.sliver; break;
      case Reason::flatten: ++R.rejected.flatten; break;
      case Reason::deviation: ++R.rejected.deviation; break;
    }
    D.rejected.insert(edge_key(en.a, en.b));
  }

  // --- compact the coarse mesh ---
  std::vector<int> vmap(nv, -1);
  std::vector<char> pinned(nv, 0);
  for (int v : opt.pinned_vertices) pinned[v] = 1;
  int ncv = 0;
  for (int v = 0; v < nv; ++v)
    if (D.v_alive[v] && !D.vf[v].empty()) {
      vmap[v] = ncv++;
      R.coarse_vertex_origin.push_back(v);
      R.coarse_vertex_feature.push_back(D.vfeat[v]);
      R.coarse_vertex_pinned.push_back(pinned[v]);
    }
  R.coarse.V.resize(ncv, 3);
  for (int v = 0; v < nv; ++v)
    if (vmap[v] >= 0) R.coarse.V.row(vmap[v]) = D.X[v].transpose();
  std::vector<int> fmap(nf, -1), fids;
  for (int f = 0; f < nf; ++f)
    if (D.face_alive[f]) fmap[f] = static_cast<int>(fids.size()), fids.push_back(f);
  const int ncf = static_cast<int>(fids.size());
  R.coarse.F.resize(ncf, 3);
  if (fine.face_entity.size()) R.coarse.face_entity.resize(ncf);
  for (int i = 0; i < ncf; ++i) {
    for (int j = 0; j < 3; ++j) R.coarse.F(i, j) = vmap[D.F[fids[i]][j]];
    if (fine.face_entity.size()) R.coarse.face_entity[i] = fine.face_entity[fids[i]];
  }
  R.coarse.physicals = fine.physicals;
  R.reached_target = ncf <= R.target_faces;
  R.message = (R.reached_target ? "reached " : "target not reached: stopped at ") + std::to_string(ncf) +
              " faces (target " + std::to_string(R.target_faces) + ", input " + std::to_string(nf) + ") after " +
              std::to_string(R.collapses) + " collapses (" + std::to_string(R.deferred) +
              " put off for their distance to the dense surface); " + std::to_string(R.rejected.total()) +
              " refused collapses (link " + std::to_string(R.rejected.link) + ", feature " +
              std::to_string(R.rejected.feature) + ", boundary " + std::to_string(R.rejected.boundary) +
              ", valence " + std::to_string(R.rejected.valence) + ", fold " + std::to_string(R.rejected.fold) +
              ", sliver " + std::to_string(R.rejected.sliver) + ", flatten " + std::to_string(R.rejected.flatten) +
              ", deviation " + std::to_string(R.rejected.deviation) + ")";
  if (!R.reached_target && R.fewest_faces > R.target_faces)
    R.message += "; keeping the topology, " + std::to_string(R.corners) + " corners and the feature curves needs at least " +
                 std::to_string(R.fewest_faces) + " faces";

  if (opt.build_map) {
    CoarseMap& M = R.map;
    M.fine_V = fine.V;
    M.fine_F = fine.F;
    M.coarse_V = R.coarse.V;
    M.coarse_F = R.coarse.F;
    M.coarse_face_id = fids;
    M.face_to_coarse = fmap;
    M.face_rec_start.assign(nf + 1, 0);
    for (int f : M.rec_face) ++M.face_rec_start[f + 1];
    for (int f = 0; f < nf; ++f) M.face_rec_start[f + 1] += M.face_rec_start[f];
    M.face_rec.resize(M.rec_face.size());
    std::vector<int> fill(M.face_rec_start.begin(), M.face_rec_start.end() - 1);
    for (int c = 0; c < M.num_collapses(); ++c)
      for (int k = M.rec_face_start[c]; k < M.rec_face_start[c + 1]; ++k) M.face_rec[fill[M.rec_face[k]]++] = c;
    M.vertex_coarse_face.resize(nv);
    M.vertex_coarse_bary.resize(nv, 3);
    for (int v = 0; v < nv; ++v) {
      M.vertex_coarse_face[v] = fmap[D.pt_face[v]];
      M.vertex_coarse_bary.row(v) = D.pt_bary[v].transpose();
    }
    index_fine_vertices(M);
  }
  R.seconds_flatten = D.t_flatten;
  R.seconds_tracking = D.t_track;
  R.seconds_total = seconds_since(t0);
  return R;
}

}  // namespace hocurve
