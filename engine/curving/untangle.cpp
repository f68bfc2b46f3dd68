// In-surface untangling by harmonic extension of the fixed nodes' in-plane displacement over a
// small patch (the displacement-propagation idea of a posteriori high-order meshing, as in
// Persson and Peraire's curved meshes by solid mechanics, here a Laplacian restricted to the
// surface: nodes move in the patch's plane and go back onto the fitted surface).
#include "engine/curving/untangle.hpp"

#include "engine/core/stopwatch.hpp"
#include "engine/curving/place_nodes.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <limits>
#include <unordered_map>

namespace hocurve {

Eigen::Vector3d SurfaceOfFaces::point(int f, const Eigen::Vector3d& xi) const {
  if (planar && (*planar)[f] >= 0) {
    // A flat patch's faces keep their nodes in their plane (flatten_planar_patches).
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) x += xi[j] * mesh->V.row(mesh->F(f, j)).transpose();
    return x;
  }
  return blend_point(*mesh, *wedges, *fits, f, xi, face_fits ? (*face_fits)[f] : nullptr);
}

namespace {

/// Faces within `rings` rings of seed across non-feature edges shared by two faces, leaving out
/// `used` and frozen faces; sorted.
std::vector<int> grow_patch(const Topology& T, const std::vector<char>& fixed_edges, const SurfaceOfFaces& S,
                            int seed, int rings, const std::vector<char>& used) {
  std::vector<int> out{seed}, front{seed};
  for (int r = 0; r < rings; ++r) {
    std::vector<int> next;
    for (int f : front)
      for (int j = 0; j < 3; ++j) {
        const int e = T.FE(f, j);
        if (fixed_edges[e] || T.edge_faces[e].size() != 2) continue;
        const int g = T.edge_faces[e][0] == f ? T.edge_faces[e][1] : T.edge_faces[e][0];
        if (used[g] || S.frozen(g) || std::find(out.begin(), out.end(), g) != out.end()) continue;
        out.push_back(g);
        next.push_back(g);
      }
    front = std::move(next);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// New positions of a patch's free nodes (global node indices), or none when the patch cannot be
/// mapped to a plane or the solve fails.
struct PatchMove {
  std::vector<int> nodes;
  std::vector<Eigen::Vector3d> positions;
};

struct PatchNode {
  int global = 0;
  bool free = false;
  int faces[2] = {-1, -1};  ///< patch faces holding the node (the first is its home face)
  int local = 0;            ///< its index in the home face's Gmsh order
};

bool untangle_patch(const HighOrderMesh& hm, const Topology& T, const std::vector<char>& fixed_edges,
                    const SurfaceOfFaces& S, const std::vector<int>& faces, const UntangleOptions& opt,
                    const Eigen::MatrixXd& ref, const Eigen::MatrixXi& lattice, PatchMove& move) {
  const int p = hm.order, nn = triangle_node_count(p), npe = hm.nodes_per_edge();
  const int nv = static_cast<int>(hm.V.rows());
  const int ne_nodes = static_cast<int>(hm.edge_nodes.rows());
  auto in_patch = [&](int f) { return std::binary_search(faces.begin(), faces.end(), f); };

  // The plane: normal to the faces' mean normal, each face within min_chart_cos of it.
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> unit(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    const int f = faces[i];
    const Eigen::Vector3d a = hm.V.row(hm.F(f, 0)), b = hm.V.row(hm.F(f, 1)), c = hm.V.row(hm.F(f, 2));
    const Eigen::Vector3d cr = (b - a).cross(c - a);
    n += cr;
    unit[i] = cr.normalized();
  }
  if (!(n.norm() > 0)) return false;
  n.normalize();
  for (const Eigen::Vector3d& u : unit)
    if (!(u.dot(n) >= opt.min_chart_cos)) return false;
  const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  auto chart = [&](const Eigen::Vector3d& x) { return Eigen::Vector2d(t1.dot(x), t2.dot(x)); };

  // The patch's nodes: fixed are corners, nodes of feature edges and of edges on the patch's rim.
  std::vector<PatchNode> nodes;
  std::unordered_map<int, int> local_of;
  std::vector<std::vector<int>> face_local(faces.size(), std::vector<int>(nn));
  std::vector<int> buf(nn);
  for (size_t i = 0; i < faces.size(); ++i) {
    element_node_indices(hm, faces[i], buf.data());
    for (int k = 0; k < nn; ++k) {
      const int g = buf[k];
      auto [it, fresh] = local_of.emplace(g, static_cast<int>(nodes.size()));
      if (fresh) {
        PatchNode pn;
        pn.global = g;
        pn.faces[0] = faces[i];
        pn.local = k;
        if (g >= nv + ne_nodes) {
          pn.free = true;
        } else if (g >= nv) {
          const int e = (g - nv) / npe;
          pn.free = !fixed_edges[e] && T.edge_faces[e].size() == 2 && in_patch(T.edge_faces[e][0]) &&
                    in_patch(T.edge_faces[e][1]);
        }
        nodes.push_back(pn);
      } else {
        nodes[it->second].faces[1] = faces[i];
      }
      face_local[i][k] = it->second;
    }
  }

  // Straight positions in the plane, and the fixed nodes' in-plane displacement: each node's
  // projection onto its home face's plane, the inverse of going back onto the surface.
  const int m = static_cast<int>(nodes.size());
  std::vector<Eigen::Vector2d> straight(m), shift(m, Eigen::Vector2d::Zero());
  for (int l = 0; l < m; ++l) {
    const PatchNode& pn = nodes[l];
    const int f = pn.faces[0];
    const Eigen::Vector3d a = hm.V.row(hm.F(f, 0)), b = hm.V.row(hm.F(f, 1)), c = hm.V.row(hm.F(f, 2));
    const Eigen::Vector3d x0 = a + ref(pn.local, 0) * (b - a) + ref(pn.local, 1) * (c - a);
    straight[l] = chart(x0);
    if (pn.free || pn.global < nv) continue;
    const Eigen::Vector3d nf = (b - a).cross(c - a).normalized();
    Eigen::Vector3d x = node_position(hm, pn.global);
    x -= (x - a).dot(nf) * nf;
    shift[l] = chart(x) - straight[l];
  }

  // P1 Laplacian on each face's node lattice, weighted by 1 / the face's area: small faces bend
  // less, so the large ones round a needle take up the displacement.
  std::vector<int> reduced(m, -1);
  int nfree = 0;
  for (int l = 0; l < m; ++l)
    if (nodes[l].free) reduced[l] = nfree++;
  if (nfree == 0) return false;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nfree, 2);
  std::vector<int> at((p + 1) * (p + 1), -1);
  for (int k = 0; k < nn; ++k) at[lattice(k, 0) * (p + 1) + lattice(k, 1)] = k;
  auto add_triangle = [&](const std::vector<int>& fl, int k0, int k1, int k2, double w) {
    const int l[3] = {fl[k0], fl[k1], fl[k2]};
    Eigen::Vector2d edge[3];
    for (int i = 0; i < 3; ++i) edge[i] = straight[l[(i + 2) % 3]] - straight[l[(i + 1) % 3]];
    const double area2 = edge[0].x() * edge[1].y() - edge[0].y() * edge[1].x();
    if (!(std::abs(area2) > 0)) return;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const double kij = w * edge[i].dot(edge[j]) / (2 * std::abs(area2));
        if (reduced[l[i]] < 0) continue;
        if (reduced[l[j]] >= 0) trip.emplace_back(reduced[l[i]], reduced[l[j]], kij);
        else rhs.row(reduced[l[i]]) -= kij * shift[l[j]].transpose();
      }
  };
  for (size_t i = 0; i < faces.size(); ++i) {
    const int f = faces[i];
    const Eigen::Vector3d a = hm.V.row(hm.F(f, 0)), b = hm.V.row(hm.F(f, 1)), c = hm.V.row(hm.F(f, 2));
    const double w = 1 / (b - a).cross(c - a).norm();
    for (int ii = 0; ii < p; ++ii)
      for (int jj = 0; ii + jj < p; ++jj) {
        add_triangle(face_local[i], at[ii * (p + 1) + jj], at[(ii + 1) * (p + 1) + jj], at[ii * (p + 1) + jj + 1], w);
        if (ii + jj + 2 <= p)
          add_triangle(face_local[i], at[(ii + 1) * (p + 1) + jj], at[(ii + 1) * (p + 1) + jj + 1],
                       at[ii * (p + 1) + jj + 1], w);
      }
  }
  Eigen::SparseMatrix<double> K(nfree, nfree);
  K.setFromTriplets(trip.begin(), trip.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(K);
  if (solver.info() != Eigen::Success) return false;
  const Eigen::MatrixXd u = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !u.allFinite()) return false;

  // Back onto the surface through the patch face that holds the moved point best.
  move.nodes.clear();
  move.positions.clear();
  for (int l = 0; l < m; ++l) {
    if (!nodes[l].free) continue;
    const Eigen::Vector2d y = straight[l] + u.row(reduced[l]).transpose();
    double best = -std::numeric_limits<double>::infinity();
    int best_face = -1;
    Eigen::Vector3d best_xi;
    for (int f : nodes[l].faces) {
      if (f < 0) continue;
      const Eigen::Vector2d a = chart(hm.V.row(hm.F(f, 0))), b = chart(hm.V.row(hm.F(f, 1))),
                            c = chart(hm.V.row(hm.F(f, 2)));
      Eigen::Matrix2d M;
      M << b - a, c - a;
      const Eigen::Vector2d uv = M.inverse() * (y - a);
      const Eigen::Vector3d xi(1 - uv.x() - uv.y(), uv.x(), uv.y());
      if (xi.minCoeff() > best) best = xi.minCoeff(), best_face = f, best_xi = xi;
    }
    if (best_face < 0 || !best_xi.allFinite()) return false;
    move.nodes.push_back(nodes[l].global);
    move.positions.push_back(S.point(best_face, best_xi));
  }
  return true;
}

/// Checks of faces at q (in faces' order).
std::vector<ElementValidity> check_faces(const HighOrderMesh& hm, const JacobianBasis& B,
                                         const std::vector<int>& faces, const ValidityOptions& q) {
  std::vector<ElementValidity> out;
  out.reserve(faces.size());
  for (int f : faces) out.push_back(check_element(B, element_nodes(hm, f), q));
  return out;
}

}  // namespace

UntangleResult untangle_in_surface(const Topology& T, const std::vector<char>& fixed_edges,
                                   const SurfaceOfFaces& surface, const ValidityOptions& validity,
                                   HighOrderMesh& hm, const UntangleOptions& opt,
                                   std::vector<ElementValidity>* checks) {
  const auto t0 = Clock::now();
  UntangleResult R;
  if (!opt.enabled || hm.order < 2 || fixed_edges.size() != static_cast<size_t>(T.num_edges())) return R;
  ValidityOptions q = validity;
  q.min_scaled_jacobian = std::max(validity.min_scaled_jacobian, validity.quality_floor);
  std::vector<ElementValidity> ev = check_elements(hm, q);
  const int nf = hm.num_faces();
  std::vector<int> targets;
  for (int f = 0; f < nf; ++f)
    if (!ev[f].valid && !ev[f].degenerate && !surface.frozen(f)) targets.push_back(f);
  R.targets = static_cast<long long>(targets.size());
  if (targets.empty()) {
    if (checks) *checks = std::move(ev);
    R.seconds = seconds_since(t0);
    return R;
  }

  const JacobianBasis B(hm.order);
  const Eigen::MatrixXd ref = triangle_reference_nodes(hm.order, hm.distribution);
  const Eigen::MatrixXi lattice = triangle_lattice(hm.order);
  std::vector<char> used(nf, 0);
  for (int t : targets) {
    if (used[t]) continue;
    // The smallest patch that clears every face, else the one that leaves fewest below.
    PatchMove best;
    std::vector<int> best_faces;
    long long best_below = -1;
    size_t last_size = 0;
    for (int rings = 1; rings <= opt.max_rings; ++rings) {
      const std::vector<int> faces = grow_patch(T, fixed_edges, surface, t, rings, used);
      if (faces.size() == last_size) break;  // walled in by features: no larger patch
      last_size = faces.size();
      ++R.patches;
      PatchMove move;
      if (!untangle_patch(hm, T, fixed_edges, surface, faces, opt, ref, lattice, move)) continue;
      std::vector<Eigen::Vector3d> old(move.nodes.size());
      for (size_t i = 0; i < move.nodes.size(); ++i) {
        old[i] = node_position(hm, move.nodes[i]);
        set_node_position(hm, move.nodes[i], move.positions[i]);
      }
      const std::vector<ElementValidity> after = check_faces(hm, B, faces, q);
      for (size_t i = 0; i < move.nodes.size(); ++i) set_node_position(hm, move.nodes[i], old[i]);
      long long below_before = 0, below_after = 0;
      bool kept_clear = true;
      for (size_t i = 0; i < faces.size(); ++i) {
        below_before += !ev[faces[i]].valid;
        below_after += !after[i].valid;
        kept_clear = kept_clear && (after[i].valid || !ev[faces[i]].valid);
      }
      if (kept_clear && below_after < below_before && (best_below < 0 || below_after < best_below)) {
        best = std::move(move);
        best_faces = faces;
        best_below = below_after;
        if (below_after == 0) break;
      }
    }
    used[t] = 1;
    if (best_below < 0) continue;
    for (size_t i = 0; i < best.nodes.size(); ++i) set_node_position(hm, best.nodes[i], best.positions[i]);
    const std::vector<ElementValidity> after = check_faces(hm, B, best_faces, q);
    for (size_t i = 0; i < best_faces.size(); ++i) {
      const int f = best_faces[i];
      R.cleared += !ev[f].valid && after[i].valid;
      ev[f] = after[i];
      used[f] = 1;
    }
    ++R.kept;
  }
  if (checks) *checks = std::move(ev);
  R.seconds = seconds_since(t0);
  return R;
}

}  // namespace hocurve
