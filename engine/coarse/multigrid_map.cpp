#include "engine/coarse/multigrid_map.hpp"

#include "engine/core/error.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <string>

namespace hocurve {

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a[0] * b[1] - a[1] * b[0]; }

Eigen::Vector3d bary_in(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                        const Eigen::Vector2d& q) {
  const double A = cross2(b - a, c - a);
  const double l0 = cross2(c - b, q - b) / A, l1 = cross2(a - c, q - c) / A;
  return {l0, l1, 1.0 - l0 - l1};
}

std::array<int, 3> post_local(const std::array<std::uint8_t, 3>& t, int post) {
  std::array<int, 3> r{t[0], t[1], t[2]};
  for (int& v : r)
    if (v == 0 || v == 1) v = post;
  return r;
}

Eigen::Vector3d interpolate(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f, const Eigen::Vector3d& b) {
  return b[0] * V.row(F(f, 0)).transpose() + b[1] * V.row(F(f, 1)).transpose() +
         b[2] * V.row(F(f, 2)).transpose();
}

/// One collapse applied to (face, bary): forward maps pre -> post, backward post -> pre.
void step(const CoarseMap& M, int c, bool forward, int& face, Eigen::Vector3d& bary, MapQueryStats* stats) {
  const int f0 = M.rec_face_start[c], f1 = M.rec_face_start[c + 1];
  const int u0 = M.rec_uv_start[c];
  const int n = M.rec_uv_start[c + 1] - u0 - 1;
  const int post = M.rec_post_reuses[c] ? 0 : n;
  const Eigen::Vector2d* uv = M.rec_uv.data() + u0;
  std::array<int, 3> src{};
  bool found = false;
  for (int k = f0; k < f1; ++k)
    if (M.rec_face[k] == face) {
      const auto& t = M.rec_face_local[k];
      src = forward ? std::array<int, 3>{t[0], t[1], t[2]} : post_local(t, post);
      found = true;
      break;
    }
  if (!found) throw std::logic_error("coarse map: face " + std::to_string(face) + " not in collapse record");
  const Eigen::Vector2d q = bary[0] * uv[src[0]] + bary[1] * uv[src[1]] + bary[2] * uv[src[2]];
  std::array<int, 3> tris[128];
  int ids[128];
  int nt = 0;
  for (int k = f0; k < f1 && nt < 128; ++k) {
    if (forward && M.rec_face_removed[k]) continue;
    const auto& t = M.rec_face_local[k];
    tris[nt] = forward ? post_local(t, post) : std::array<int, 3>{t[0], t[1], t[2]};
    ids[nt++] = M.rec_face[k];
  }
  const int hit = locate_uv(uv, tris, nt, q, bary, stats);
  face = ids[hit];
  if (stats) ++stats->steps;
}

}  // namespace

int locate_uv(const Eigen::Vector2d* uv, const std::array<int, 3>* tris, int ntris, const Eigen::Vector2d& q,
              Eigen::Vector3d& bary, MapQueryStats* stats, double tol) {
  int best = -1;
  double best_min = -1e300;
  Eigen::Vector3d best_b;
  for (int t = 0; t < ntris; ++t) {
    const Eigen::Vector3d b = bary_in(uv[tris[t][0]], uv[tris[t][1]], uv[tris[t][2]], q);
    const double mn = b.minCoeff();
    if (mn > best_min) best_min = mn, best = t, best_b = b;
    if (mn >= 0) break;  // inside: no other triangle can do better than "inside"
  }
  if (best_min < -tol && stats) {
    ++stats->clamped;
    stats->worst_outside = std::max(stats->worst_outside, -best_min);
  }
  for (int k = 0; k < 3; ++k) best_b[k] = std::max(best_b[k], 0.0);
  bary = best_b / best_b.sum();
  return best;
}

SurfacePoint fine_to_coarse(const CoarseMap& M, int fine_face, const Eigen::Vector3d& bary, MapQueryStats* stats) {
  if (fine_face < 0 || fine_face >= M.fine_F.rows())
    throw InputError("fine_to_coarse", "fine face " + std::to_string(fine_face) + " out of range");
  int face = fine_face;
  Eigen::Vector3d b = bary / bary.sum();
  int t = 0;  // next collapse that may apply
  for (;;) {
    const int* beg = M.face_rec.data() + M.face_rec_start[face];
    const int* end = M.face_rec.data() + M.face_rec_start[face + 1];
    const int* it = std::lower_bound(beg, end, t);
    if (it == end) break;
    step(M, *it, true, face, b, stats);
    t = *it + 1;
  }
  SurfacePoint sp;
  sp.face = M.face_to_coarse[face];
  if (sp.face < 0) throw std::logic_error("fine_to_coarse: ended in a collapsed face");
  if (!M.split_next.empty()) {  // the decimated face was split: the piece that holds b
    const Eigen::Vector3d base = b;
    double best = -1e300;
    for (int f = sp.face; f >= 0; f = M.split_next[f]) {
      const Eigen::Vector3d l = M.split_to_base[f].inverse() * base;
      if (l.minCoeff() > best) best = l.minCoeff(), sp.face = f, b = l;
    }
    for (int k = 0; k < 3; ++k) b[k] = std::max(b[k], 0.0);
    b /= b.sum();
  }
  sp.bary = b;
  sp.position = interpolate(M.coarse_V, M.coarse_F, sp.face, b);
  return sp;
}

SurfacePoint coarse_to_fine(const CoarseMap& M, int coarse_face, const Eigen::Vector3d& bary, MapQueryStats* stats) {
  if (coarse_face < 0 || coarse_face >= M.coarse_F.rows())
    throw InputError("coarse_to_fine", "coarse face " + std::to_string(coarse_face) + " out of range");
  int face = M.coarse_face_id[coarse_face];
  Eigen::Vector3d b = bary / bary.sum();
  if (!M.split_to_base.empty()) b = M.split_to_base[coarse_face] * b;
  int t = M.num_collapses();  // collapses < t may apply
  for (;;) {
    const int* beg = M.face_rec.data() + M.face_rec_start[face];
    const int* end = M.face_rec.data() + M.face_rec_start[face + 1];
    const int* it = std::lower_bound(beg, end, t);
    if (it == beg) break;
    --it;
    step(M, *it, false, face, b, stats);
    t = *it;
  }
  SurfacePoint sp;
  sp.face = face;
  sp.bary = b;
  sp.position = interpolate(M.fine_V, M.fine_F, face, b);
  return sp;
}

void index_fine_vertices(CoarseMap& M) {
  const int nv = static_cast<int>(M.vertex_coarse_face.size()), ncf = static_cast<int>(M.coarse_F.rows());
  M.cf_start.assign(ncf + 1, 0);
  for (int v = 0; v < nv; ++v) ++M.cf_start[M.vertex_coarse_face[v] + 1];
  for (int f = 0; f < ncf; ++f) M.cf_start[f + 1] += M.cf_start[f];
  M.cf_vertices.resize(nv);
  std::vector<int> fill(M.cf_start.begin(), M.cf_start.end() - 1);
  for (int v = 0; v < nv; ++v) M.cf_vertices[fill[M.vertex_coarse_face[v]]++] = v;
}

Eigen::SparseMatrix<double> prolongation(const CoarseMap& M) {
  const int n = static_cast<int>(M.vertex_coarse_face.size());
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(3 * static_cast<size_t>(n));
  for (int v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k)
      if (M.vertex_coarse_bary(v, k) != 0)
        trip.emplace_back(v, M.coarse_F(M.vertex_coarse_face[v], k), M.vertex_coarse_bary(v, k));
  Eigen::SparseMatrix<double> P(n, M.coarse_V.rows());
  P.setFromTriplets(trip.begin(), trip.end());
  return P;
}

Eigen::MatrixXd fine_vertices_on_coarse(const CoarseMap& M) {
  const int n = static_cast<int>(M.vertex_coarse_face.size());
  Eigen::MatrixXd P(n, 3);
  for (int v = 0; v < n; ++v)
    P.row(v) = interpolate(M.coarse_V, M.coarse_F, M.vertex_coarse_face[v], M.vertex_coarse_bary.row(v).transpose())
                   .transpose();
  return P;
}

}  // namespace hocurve
