#include "engine/coarse/flatten.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <map>
#include <numbers>

namespace hocurve {

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a[0] * b[1] - a[1] * b[0]; }

/// Signed area of a UV triangle.
double uv_area(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return 0.5 * cross2(b - a, c - a);
}

double uv_quality(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const double l2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return l2 > 0 ? 4 * std::sqrt(3.0) * uv_area(a, b, c) / l2 : 0;
}

double angle_at(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d u = a - o, v = b - o;
  return std::atan2(std::abs(cross2(u, v)), u.dot(v));
}

/// Adds one triangle's LSCM energy (Dirichlet minus signed area, as 1/2 x^T Q x) to Q, where
/// unknown i has entries 2i (u) and 2i+1 (v); X are the triangle's 3D corners.
void add_lscm(Eigen::MatrixXd& Q, const std::array<int, 3>& t, const std::array<Eigen::Vector3d, 3>& X) {
  for (int k = 0; k < 3; ++k) {
    const int i = t[(k + 1) % 3], j = t[(k + 2) % 3];
    const Eigen::Vector3d e1 = X[(k + 1) % 3] - X[k], e2 = X[(k + 2) % 3] - X[k];
    const double cr = e1.cross(e2).norm();
    const double w = cr > 0 ? 0.5 * e1.dot(e2) / cr : 0.0;  // cot(angle at k) / 2
    for (int d = 0; d < 2; ++d) {
      Q(2 * i + d, 2 * i + d) += w, Q(2 * j + d, 2 * j + d) += w;
      Q(2 * i + d, 2 * j + d) -= w, Q(2 * j + d, 2 * i + d) -= w;
    }
  }
  // Signed area: 1/2 sum over directed edges (i -> j) of (u_i v_j - u_j v_i).
  for (int k = 0; k < 3; ++k) {
    const int i = t[k], j = t[(k + 1) % 3];
    Q(2 * i, 2 * j + 1) -= 0.5, Q(2 * j + 1, 2 * i) -= 0.5;
    Q(2 * j, 2 * i + 1) += 0.5, Q(2 * i + 1, 2 * j) += 0.5;
  }
}

bool segments_cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                    const Eigen::Vector2d& d) {
  const double d1 = cross2(b - a, c - a), d2 = cross2(b - a, d - a);
  const double d3 = cross2(d - c, a - c), d4 = cross2(d - c, b - c);
  return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0)) && d1 != 0 && d2 != 0 && d3 != 0 && d4 != 0;
}

}  // namespace

std::array<int, 3> post_triangle(const CollapsePatch& P, int k) {
  const int post = P.post_reuses_survivor_uv ? 0 : static_cast<int>(P.X.size());
  std::array<int, 3> t = P.faces[k];
  for (int& v : t)
    if (v == 0 || v == 1) v = post;
  return t;
}

Eigen::Vector3d uv_barycentric(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                               const Eigen::Vector2d& q) {
  const double A = cross2(b - a, c - a);
  const double l1 = cross2(c - b, q - b) / A, l2 = cross2(a - c, q - c) / A;
  return {l1, l2, 1.0 - l1 - l2};
}

PatchFlattening flatten_collapse(const CollapsePatch& P, const FlattenOptions& opt) {
  PatchFlattening out;
  const int n = static_cast<int>(P.X.size());
  const int N = n + 1;  // pre unknowns + post survivor
  Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(2 * N, 2 * N);
  const int nf = static_cast<int>(P.faces.size());
  for (int k = 0; k < nf; ++k) {
    const auto& t = P.faces[k];
    add_lscm(Q, t, {P.X[t[0]], P.X[t[1]], P.X[t[2]]});
    if (P.removed[k]) continue;
    const auto tp = post_triangle(P, k);
    std::array<Eigen::Vector3d, 3> Xp;
    for (int c = 0; c < 3; ++c) Xp[c] = (t[c] == 0 || t[c] == 1) ? P.p : P.X[t[c]];
    add_lscm(Q, tp, Xp);
  }
  // Free unknowns: all but u0,v0,u1,v1 (pinned), and the post survivor if it reuses local 0.
  std::vector<int> idx;  // free scalar entries
  for (int v = 2; v < N; ++v) {
    if (v == n && P.post_reuses_survivor_uv) continue;
    idx.push_back(2 * v);
    if (v != P.curve_pin) idx.push_back(2 * v + 1);
  }
  const int m = static_cast<int>(idx.size());
  Eigen::MatrixXd Qff(m, m);
  Eigen::VectorXd rhs(m);
  for (int a = 0; a < m; ++a) {
    for (int b = 0; b < m; ++b) Qff(a, b) = Q(idx[a], idx[b]);
    rhs[a] = -Q(idx[a], 2);  // pinned: u1 = 1, all other pinned entries 0
  }
  Eigen::LDLT<Eigen::MatrixXd> ldlt(Qff);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
    out.why = "solve";
    return out;
  }
  const Eigen::VectorXd x = ldlt.solve(rhs);
  if (!x.allFinite()) {
    out.why = "nan";
    return out;
  }
  out.uv.assign(N, Eigen::Vector2d::Zero());
  out.uv[1] = {1.0, 0.0};
  for (int a = 0; a < m; ++a) out.uv[idx[a] / 2][idx[a] % 2] = x[a];
  if (P.post_reuses_survivor_uv) out.uv[n] = out.uv[0];
  const auto& uv = out.uv;
  if (P.curve_pin >= 0 && !(uv[P.curve_pin][0] > 1 + opt.min_area)) {
    out.why = "curve";
    return out;
  }

  // Flips, degeneracies and quality, pre and post.
  double ang_s = 0, ang_r = 0, ang_p = 0;
  const int post = P.post_reuses_survivor_uv ? 0 : n;
  for (int k = 0; k < nf; ++k) {
    for (int phase = 0; phase < 2; ++phase) {
      if (phase == 1 && P.removed[k]) continue;
      const auto t = phase == 0 ? P.faces[k] : post_triangle(P, k);
      const Eigen::Vector2d &a = uv[t[0]], &b = uv[t[1]], &c = uv[t[2]];
      if (!(uv_area(a, b, c) > opt.min_area)) {
        out.why = "flip";
        return out;
      }
      if (uv_quality(a, b, c) < opt.min_quality) {
        out.why = "quality";
        return out;
      }
      for (int j = 0; j < 3; ++j) {
        const double ang = angle_at(uv[t[j]], uv[t[(j + 1) % 3]], uv[t[(j + 2) % 3]]);
        if (phase == 0 && t[j] == 0) ang_s += ang;
        if (phase == 0 && t[j] == 1) ang_r += ang;
        if (phase == 1 && t[j] == post) ang_p += ang;
      }
    }
  }
  const double lim = 2 * std::numbers::pi + 1e-10;
  if ((P.s_interior && ang_s > lim) || (P.r_interior && ang_r > lim) ||
      (P.s_interior && ang_p > lim)) {
    out.why = "overlap";
    return out;
  }
  // Outer boundary of the pre patch (edges used once): it must be a simple polygon.
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : P.faces)
    for (int j = 0; j < 3; ++j) {
      int a = t[j], b = t[(j + 1) % 3];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<std::pair<int, int>> bnd;
  for (const auto& [e, c] : count)
    if (c == 1) bnd.push_back(e);
  for (size_t i = 0; i < bnd.size(); ++i)
    for (size_t j = i + 1; j < bnd.size(); ++j) {
      const auto [a, b] = bnd[i];
      const auto [c, d] = bnd[j];
      if (a == c || a == d || b == c || b == d) continue;
      if (segments_cross(uv[a], uv[b], uv[c], uv[d])) {
        out.why = "ring";
        return out;
      }
    }
  out.ok = true;
  return out;
}

}  // namespace hocurve
