#include "engine/curving/local_fit.hpp"

#include "engine/curving/apex_fit.hpp"
#include "engine/curving/share_exact_fits.hpp"

#include "engine/core/stopwatch.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <utility>

namespace hocurve {

namespace {

/// Monomials (u^j v^k, 1 <= j+k <= p; by degree, then descending j) of scaled coordinates.
void monomials(double u, double v, int p, double* out) {
  double pu[8], pv[8];
  pu[0] = pv[0] = 1.0;
  for (int i = 1; i <= p; ++i) pu[i] = pu[i - 1] * u, pv[i] = pv[i - 1] * v;
  int k = 0;
  for (int d = 1; d <= p; ++d)
    for (int j = d; j >= 0; --j) out[k++] = pu[j] * pv[d - j];
}

double dot(const double* a, const double* b, int n) {
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  int r = 0;
  for (; r + 4 <= n; r += 4) s0 += a[r] * b[r], s1 += a[r + 1] * b[r + 1], s2 += a[r + 2] * b[r + 2], s3 += a[r + 3] * b[r + 3];
  for (; r < n; ++r) s0 += a[r] * b[r];
  return (s0 + s1) + (s2 + s3);
}

/// Householder QR of a small k x m least-squares system (k >= m), optionally with column
/// pivoting: the algorithm of Eigen's ColPivHouseholderQR (largest remaining column norm
/// first, norms downdated, recomputed when cancellation makes the downdate unreliable), with
/// plain column loops instead of Eigen's dynamic-size kernels, whose dispatch costs more than
/// the arithmetic at these sizes (14-27 columns, 20-130 rows). Same solutions up to round-off.
class SmallQR {
 public:
  /// Factors the first m columns of A (column-major).
  void compute(const Eigen::MatrixXd& A, int m, bool pivot) {
    k_ = static_cast<int>(A.rows());
    m_ = m;
    qr_ = A.leftCols(m);
    tau_.assign(m, 0.0);
    perm_.resize(m);
    std::vector<double>& nrm = nrm_;
    std::vector<double>& direct = direct_;
    if (pivot) {
      nrm.resize(m);
      direct.resize(m);
      for (int j = 0; j < m; ++j) nrm[j] = direct[j] = std::sqrt(dot(&qr_(0, j), &qr_(0, j), k_));
    }
    for (int j = 0; j < m; ++j) perm_[j] = j;
    const double downdate_threshold = std::sqrt(std::numeric_limits<double>::epsilon());
    for (int i = 0; i < m; ++i) {
      if (pivot) {
        int best = i;
        for (int j = i + 1; j < m; ++j)
          if (nrm[j] > nrm[best]) best = j;
        if (best != i) {
          qr_.col(i).swap(qr_.col(best));
          std::swap(nrm[i], nrm[best]);
          std::swap(direct[i], direct[best]);
          std::swap(perm_[i], perm_[best]);
        }
      }
      // Reflector H = I - tau v v^T, v = (1, essential), zeroing column i below row i.
      double* ci = &qr_(0, i);
      const int len = k_ - i - 1;
      const double c0 = ci[i];
      const double tail = dot(ci + i + 1, ci + i + 1, len);
      if (tail <= std::numeric_limits<double>::min()) {
        tau_[i] = 0;
        for (int r = i + 1; r < k_; ++r) ci[r] = 0;
      } else {
        double beta = std::sqrt(c0 * c0 + tail);
        if (c0 >= 0) beta = -beta;
        const double inv = 1.0 / (c0 - beta);
        for (int r = i + 1; r < k_; ++r) ci[r] *= inv;
        tau_[i] = (beta - c0) / beta;
        ci[i] = beta;
        for (int j = i + 1; j < m; ++j) {
          double* cj = &qr_(0, j);
          const double w = tau_[i] * (cj[i] + dot(ci + i + 1, cj + i + 1, len));
          cj[i] -= w;
          for (int r = i + 1; r < k_; ++r) cj[r] -= w * ci[r];
        }
      }
      if (pivot)
        for (int j = i + 1; j < m; ++j) {
          if (nrm[j] == 0) continue;
          double t = std::abs(qr_(i, j)) / nrm[j];
          t = std::max(0.0, (1 + t) * (1 - t));
          const double q = nrm[j] / direct[j];
          if (t * q * q <= downdate_threshold) {
            nrm[j] = direct[j] = std::sqrt(dot(&qr_(i + 1, j), &qr_(i + 1, j), len));
          } else {
            nrm[j] *= std::sqrt(t);
          }
        }
    }
  }
  double diag(int i) const { return qr_(i, i); }
  /// R(i, j), i <= j (in factored column order).
  double r(int i, int j) const { return qr_(i, j); }
  /// Numerical rank as ColPivHouseholderQR counts it: pivots above tol x the largest.
  int rank(double tol) const {
    double mx = 0;
    for (int i = 0; i < m_; ++i) mx = std::max(mx, std::abs(diag(i)));
    int r = 0;
    for (int i = 0; i < m_; ++i) r += std::abs(diag(i)) > mx * tol;
    return r;
  }
  /// Q^T b (all m reflectors).
  void apply_qt(const Eigen::VectorXd& b, Eigen::VectorXd& qtb) const {
    qtb = b;
    for (int i = 0; i < m_; ++i) {
      if (tau_[i] == 0) continue;
      const double* ci = &qr_(0, i);
      const double t = tau_[i] * (qtb[i] + dot(ci + i + 1, qtb.data() + i + 1, k_ - i - 1));
      qtb[i] -= t;
      for (int r = i + 1; r < k_; ++r) qtb[r] -= t * ci[r];
    }
  }
  /// Least-squares solution on the first mm factored columns from Q^T b, in the original
  /// column order.
  void solve(const Eigen::VectorXd& qtb, int mm, Eigen::VectorXd& x) const {
    y_.resize(mm);
    for (int i = mm - 1; i >= 0; --i) {
      double s = qtb[i];
      for (int j = i + 1; j < mm; ++j) s -= qr_(i, j) * y_[j];
      y_[i] = s / diag(i);
    }
    x.resize(mm);
    for (int i = 0; i < mm; ++i) x[perm_[i]] = y_[i];
  }

 private:
  int k_ = 0, m_ = 0;
  Eigen::MatrixXd qr_;
  std::vector<double> tau_, nrm_, direct_;
  mutable std::vector<double> y_;
  std::vector<int> perm_;
};

/// Column-pivoted QR solve of min |As c - b| over the first m columns of a column-scaled As
/// (scale: the factors that were applied, multiplied back into c); false when rank deficient.
/// basic: minimum-norm solution of the system truncated at rank tolerance rank_tol.
bool solve_scaled(const Eigen::MatrixXd& As, int m, const Eigen::VectorXd& b, const Eigen::VectorXd& scale,
                  double rank_tol, Eigen::VectorXd& c, double* pivot_ratio = nullptr, bool basic = false) {
  if (basic) {
    // Minimum-norm solution of the rank-truncated system: directions the points leave
    // (nearly) open get no curvature instead of arbitrary pivoting choices.
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
    cod.setThreshold(rank_tol);
    cod.compute(As.leftCols(m));
    c = cod.solve(b);
    c.array() *= scale.head(m).array();
    if (pivot_ratio) *pivot_ratio = 0;
    return c.allFinite();
  }
  SmallQR qr;
  qr.compute(As, m, true);
  if (qr.rank(rank_tol) < m) return false;
  if (pivot_ratio) {
    const double r0 = std::abs(qr.diag(0));
    *pivot_ratio = r0 > 0 ? std::abs(qr.diag(m - 1)) / r0 : 0.0;
  }
  Eigen::VectorXd qtb;
  qr.apply_qt(b, qtb);
  qr.solve(qtb, m, c);
  c.array() *= scale.head(m).array();
  return c.allFinite();
}

}  // namespace

void tangent_frame(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  Eigen::Vector3d a = std::abs(n.x()) >= std::abs(n.y()) && std::abs(n.x()) >= std::abs(n.z())
                          ? Eigen::Vector3d::UnitY()
                          : Eigen::Vector3d::UnitX();
  t1 = (a - a.dot(n) * n).normalized();
  t2 = n.cross(t1);
}

namespace {

/// sum_k c[k] x monomial_k(u, v) for degree P: the loops of monomials() with a constant bound
/// (unrolled), same operations in the same order.
template <int P>
double poly_value(const double* c, double u, double v) {
  double pu[P + 1], pv[P + 1];
  pu[0] = pv[0] = 1.0;
  for (int i = 1; i <= P; ++i) pu[i] = pu[i - 1] * u, pv[i] = pv[i - 1] * v;
  double s = 0;
  int k = 0;
  for (int d = 1; d <= P; ++d)
    for (int j = d; j >= 0; --j) s += c[k++] * (pu[j] * pv[d - j]);
  return s;
}

}  // namespace

double LocalFit::height(double u, double v) const {
  if (degree <= 0) return 0.0;
  const double x = u / h, y = v / h;
  if (c.size() == fit_coefficients(degree)) {
    switch (degree) {
      case 1: return poly_value<1>(c.data(), x, y) * h;
      case 2: return poly_value<2>(c.data(), x, y) * h;
      case 3: return poly_value<3>(c.data(), x, y) * h;
      case 4: return poly_value<4>(c.data(), x, y) * h;
      case 5: return poly_value<5>(c.data(), x, y) * h;
      case 6: return poly_value<6>(c.data(), x, y) * h;
      default: break;
    }
  }
  double mono[40];
  monomials(x, y, degree, mono);
  double s = 0;
  for (Eigen::Index k = 0; k < c.size(); ++k) s += c[k] * mono[k];
  return s * h;
}

double LocalFit::quadric_height(double u, double v) const {
  // G w^2 - beta w + gamma = 0, the root through o (w = 0 at u = v = 0) in its stable form.
  const double beta = 1 - q[5] * u - q[6] * v;
  const double gamma = q[0] * u + q[1] * v + q[2] * u * u + 2 * q[3] * u * v + q[4] * v * v;
  const double disc = std::max(beta * beta - 4 * q[7] * gamma, 0.0);
  const double den = beta + std::sqrt(disc);
  return den > 1e-3 ? 2 * gamma / den : gamma;
}

namespace {
/// The quadric sheet's point at (u, v) (frame coordinates), its tangents and unit normal.
struct QuadricPoint {
  Eigen::Vector3d s, su, sv, nu;
};
QuadricPoint quadric_point(const LocalFit& F, double u, double v) {
  const double* q = F.q;
  const double w = F.quadric_height(u, v);
  // Gradient of w - (a u + b v + A u^2 + 2B uv + C v^2 + D u w + E v w + G w^2).
  const double fu = -(q[0] + 2 * q[2] * u + 2 * q[3] * v + q[5] * w);
  const double fv = -(q[1] + 2 * q[3] * u + 2 * q[4] * v + q[6] * w);
  double fw = 1 - q[5] * u - q[6] * v - 2 * q[7] * w;
  if (std::abs(fw) < 1e-3) fw = fw < 0 ? -1e-3 : 1e-3;
  QuadricPoint P;
  P.s = u * F.t1 + v * F.t2 + w * F.n;
  P.su = F.t1 - fu / fw * F.n;
  P.sv = F.t2 - fv / fw * F.n;
  P.nu = (fu * F.t1 + fv * F.t2 + fw * F.n).normalized();
  if (fw < 0) P.nu = -P.nu;
  return P;
}
}  // namespace

Eigen::Vector3d LocalFit::coords(const Eigen::Vector3d& qp) const {
  const Eigen::Vector3d d = qp - o;
  const double x = d.dot(t1), y = d.dot(t2), w = d.dot(n);
  if (quadric_ref) {
    // Closest point on the quadric by Gauss-Newton from the point straight below: heights
    // along the quadric's normal, as the torus chart's (nodes of neighbouring fits then agree
    // along the surface, not only across it).
    // Linear convergence at rate ~ distance x curvature: few steps for points near the quadric.
    double u = x, v = y;
    for (int it = 0; it < 40; ++it) {
      const QuadricPoint Q = quadric_point(*this, u, v);
      const Eigen::Vector3d r = d - Q.s;
      const double a11 = Q.su.dot(Q.su), a12 = Q.su.dot(Q.sv), a22 = Q.sv.dot(Q.sv);
      const double b1 = Q.su.dot(r), b2 = Q.sv.dot(r), det = a11 * a22 - a12 * a12;
      if (!(det > 0)) break;
      const double du = (a22 * b1 - a12 * b2) / det, dv = (a11 * b2 - a12 * b1) / det;
      u += du, v += dv;
      if (std::abs(du) + std::abs(dv) < 1e-14 * (std::abs(u) + std::abs(v) + h)) break;
    }
    const QuadricPoint Q = quadric_point(*this, u, v);
    return {u, v, (d - Q.s).dot(Q.nu)};
  }
  if (k2 == 0) return {x, y, w};
  // Rotate about the axis (along t2 through o + rho1 n) into o's meridian plane: arc length u,
  // height wp there; |q - axis| - |rho1| written without cancellation.
  double u = x, wp = w;
  if (k1 != 0) {
    const double rho1 = 1.0 / k1, sg = rho1 > 0 ? 1.0 : -1.0;
    const double s = std::sqrt(x * x + (w - rho1) * (w - rho1));  // not hypot: slow, and no overflow here
    u = std::abs(rho1) * std::atan2(x, std::abs(rho1) - sg * w);
    wp = -sg * (x * x + w * w - 2 * w * rho1) / (s + std::abs(rho1));
  }
  // In the meridian plane (y, wp): the arc length along the tube circle (centre o + rho2 n)
  // to the point's ray from the centre (v), and the signed distance to that circle (height).
  const double rho2 = 1.0 / k2, sg2 = rho2 > 0 ? 1.0 : -1.0;
  const double r = std::sqrt(y * y + (wp - rho2) * (wp - rho2));
  const double v = std::abs(rho2) * std::atan2(y, std::abs(rho2) - sg2 * wp);
  const double z = -sg2 * (y * y + wp * wp - 2 * rho2 * wp) / (r + std::abs(rho2));
  return {u, v, z};
}

Eigen::Vector3d LocalFit::point(double u, double v, double z) const {
  if (quadric_ref) {
    const QuadricPoint Q = quadric_point(*this, u, v);
    return o + Q.s + z * Q.nu;
  }
  if (k2 == 0) return o + u * t1 + v * t2 + z * n;
  // Meridian plane: at angle v / |rho2| on the tube circle, radius |rho2| - sg2 z from its centre.
  const double rho2 = 1.0 / k2, a2 = std::abs(rho2), sg2 = rho2 > 0 ? 1.0 : -1.0;
  const double psi = v / a2, half2 = std::sin(0.5 * psi);
  const double y = (a2 - sg2 * z) * std::sin(psi);
  const double wp = 2 * rho2 * half2 * half2 + z * std::cos(psi);
  if (k1 == 0) return o + u * t1 + y * t2 + wp * n;
  // Rotate by u / |rho1| about the axis: distance to the axis sg1 (rho1 - wp).
  const double rho1 = 1.0 / k1, sg1 = rho1 > 0 ? 1.0 : -1.0;
  const double phi = u / std::abs(rho1), s = sg1 * (rho1 - wp);
  const double half = std::sin(0.5 * phi);
  return o + s * std::sin(phi) * t1 + y * t2 + (2 * rho1 * half * half + wp * std::cos(phi)) * n;
}

Eigen::Vector3d LocalFit::project(const Eigen::Vector3d& x) const {
  if (identity) return x;
  if (apex) return apex_project(x);
  if (exact) return surface->project(x);
  const Eigen::Vector3d c = coords(x);
  return point(c[0], c[1], height(c[0], c[1]));
}

namespace {

/// Weighted linear least squares min sum w_i^2 (row_i . s - z_i)^2 over N unknowns, by Jacobi-
/// scaled normal equations; row(i, row_i) returns z_i. False when the points barely determine s
/// (an LDLT pivot below min_pivot x the largest: points on a few lines, as on CAD strips).
/// residual: the weighted residual norm.
template <int N, class Row>
bool weighted_lsq(Eigen::Index k, const Eigen::VectorXd& w, const Row& row, double min_pivot,
                  Eigen::Matrix<double, N, 1>& s, double& residual) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  Mat M = Mat::Zero();
  Vec r = Vec::Zero(), x;
  for (Eigen::Index i = 0; i < k; ++i) {
    const double z = row(i, x), w2 = w[i] * w[i];
    M += w2 * x * x.transpose();
    r += w2 * z * x;
  }
  Vec dsc;
  for (int j = 0; j < N; ++j) dsc[j] = M(j, j) > 0 ? 1.0 / std::sqrt(M(j, j)) : 0.0;
  if (!(dsc.minCoeff() > 0)) return false;
  const Eigen::LDLT<Mat> ldlt(Mat(dsc.asDiagonal() * M * dsc.asDiagonal()));
  const Vec piv = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(piv.minCoeff() > min_pivot * piv.maxCoeff())) return false;
  s = dsc.asDiagonal() * ldlt.solve(dsc.asDiagonal() * r);
  if (!s.allFinite()) return false;
  residual = 0;
  for (Eigen::Index i = 0; i < k; ++i) {
    const double e = row(i, x) - x.dot(s);
    residual += w[i] * w[i] * e * e;
  }
  residual = std::sqrt(residual);
  return true;
}

}  // namespace

FitReference reference_surface(const Eigen::Vector3d& o, const Eigen::Vector3d& n, const Eigen::MatrixXd& P,
                               const Eigen::VectorXd& w, Eigen::Vector3d* normal) {
  // Weighted least squares for w = a u + b v + (A (u^2 + w^2 / 2) + 2 B u v + C (v^2 + w^2 / 2)) / 2,
  // (u, v, w) = q - o in the frame: the tilt terms absorb the frame normal's error, which would
  // otherwise bias the curvatures by ~ tilt / h, and a sphere (A = C = kappa, B = 0) fits exactly.
  FitReference ref;
  Eigen::Vector3d t1, t2;
  tangent_frame(n, t1, t2);
  ref.t1 = t1;
  ref.t2 = t2;
  if (normal) *normal = n;
  double rmax = 0;
  for (Eigen::Index i = 0; i < P.rows(); ++i) rmax = std::max(rmax, (P.row(i).transpose() - o).norm());
  if (!(rmax > 0)) return ref;
  // Points that barely determine the quadratic give no reference: a wrong one would bend every fit.
  Eigen::Matrix<double, 5, 1> s;
  const auto row = [&](Eigen::Index i, Eigen::Matrix<double, 5, 1>& x) {
    const Eigen::Vector3d d = P.row(i).transpose() - o;
    const double u = d.dot(t1), v = d.dot(t2), z = d.dot(n), w2 = 0.5 * z * z;
    x << u, v, 0.5 * (u * u + w2), u * v, 0.5 * (v * v + w2);
    return z;
  };
  if (!weighted_lsq<5>(P.rows(), w, row, 1e-6, s, ref.residual)) return ref;
  if (normal) {
    const Eigen::Vector3d n1 = n - s[0] * t1 - s[1] * t2;
    if (n1.norm() > 0 && n1.normalized().dot(n) > 0.5) *normal = n1.normalized();
  }
  // Principal curvatures (eigenvalues of [[A, B], [B, C]]) and directions.
  const double mean = 0.5 * (s[2] + s[4]);
  const double half_gap = std::hypot(0.5 * (s[2] - s[4]), s[3]);
  const double lo = mean - half_gap, hi = mean + half_gap;  // lo <= hi
  // Direction of hi: eigenvector (B, hi - A), or (hi - C, B) when that one is longer.
  Eigen::Vector2d e_hi(s[3], hi - s[2]);
  const Eigen::Vector2d alt(hi - s[4], s[3]);
  if (alt.norm() > e_hi.norm()) e_hi = alt;
  if (!(e_hi.norm() > 0)) e_hi = Eigen::Vector2d(1, 0);
  e_hi.normalize();
  // t2: the direction of larger |curvature| (the tube); t1 = t2 x n (around the axis).
  Eigen::Vector3d d_hi = e_hi[0] * t1 + e_hi[1] * t2;
  double k_big = hi, k_small = lo;
  if (std::abs(lo) > std::abs(hi)) {
    d_hi = n.cross(d_hi);  // lo's direction is perpendicular to hi's
    std::swap(k_big, k_small);
  }
  const double cap = 0.9 / rmax;  // |w| <= 0.9 |rho|: every point on the near side
  if (std::abs(k_big) * rmax < 1e-3) return ref;
  if (std::abs(k_small) * rmax < 1e-3) k_small = 0;
  // The frame of the tilt-corrected normal (curvatures change by O(tilt^2) only).
  const Eigen::Vector3d nn = normal ? *normal : n;
  ref.t2 = (d_hi - d_hi.dot(nn) * nn).normalized();
  ref.t1 = ref.t2.cross(nn);
  ref.k2 = std::clamp(k_big, -cap, cap);
  ref.k1 = std::clamp(k_small, -cap, cap);
  return ref;
}

FitReference quadric_reference(const Eigen::Vector3d& o, const Eigen::Vector3d& n, const Eigen::MatrixXd& P,
                               const Eigen::VectorXd& w) {
  FitReference ref;
  tangent_frame(n, ref.t1, ref.t2);
  Eigen::Matrix<double, 8, 1> s;
  const auto row = [&](Eigen::Index i, Eigen::Matrix<double, 8, 1>& x) {
    const Eigen::Vector3d d = P.row(i).transpose() - o;
    const double u = d.dot(ref.t1), v = d.dot(ref.t2), z = d.dot(n);
    x << u, v, u * u, 2 * u * v, v * v, u * z, v * z, z * z;
    return z;
  };
  if (!weighted_lsq<8>(P.rows(), w, row, 1e-8, s, ref.residual)) return ref;
  ref.quadric_ref = true;
  for (int j = 0; j < 8; ++j) ref.q[j] = s[j];
  return ref;
}

namespace {

/// Rows of the weighted least-squares system of fit F's frame and reference at degree `degree`:
/// A(i, j) = w_i monomial_j(u_i / h, v_i / h), b_i = w_i height_i / h, the points P then Q.
void weighted_design(const LocalFit& F, const Eigen::MatrixXd& P, const Eigen::VectorXd& w, const Eigen::MatrixXd& Q,
                     const Eigen::VectorXd& wq, int degree, Eigen::MatrixXd& A, Eigen::VectorXd& b) {
  const int k = static_cast<int>(P.rows()) + static_cast<int>(Q.rows());
  const int mmax = fit_coefficients(degree);
  A.resize(k, mmax);
  b.resize(k);
  double mono[40];
  for (int i = 0; i < k; ++i) {
    const bool is_vertex = i < P.rows();
    const Eigen::Vector3d q = is_vertex ? Eigen::Vector3d(P.row(i)) : Eigen::Vector3d(Q.row(i - P.rows()));
    const double wi = is_vertex ? w[i] : wq[i - P.rows()];
    const Eigen::Vector3d uvz = F.coords(q);
    monomials(uvz[0] / F.h, uvz[1] / F.h, degree, mono);
    for (int j = 0; j < mmax; ++j) A(i, j) = wi * mono[j];
    b[i] = wi * uvz[2] / F.h;
  }
}

}  // namespace

double leave_one_out_residual(const LocalFit& F, const Eigen::MatrixXd& P, const Eigen::VectorXd& w,
                              int lower_degree, double* lower_press, const FitDesign* design) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const int ml = lower_press && lower_degree >= 1 && lower_degree < F.degree ? fit_coefficients(lower_degree) : 0;
  if (lower_press) *lower_press = inf;
  if (F.degree < 1 || F.identity) return inf;
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  const int mf = fit_coefficients(F.degree);
  if (design && design->A.rows() == P.rows() && design->A.cols() >= mf) {
    A = design->A.leftCols(mf);  // a lower degree's monomials are the leading columns
    b = design->b;
  } else {
    weighted_design(F, P, w, Eigen::MatrixXd(), Eigen::VectorXd(), F.degree, A, b);
  }
  const int k = static_cast<int>(A.rows()), m = static_cast<int>(A.cols());
  if (k <= m) return inf;
  const Eigen::VectorXd r = b - A * F.c;
  // Column scaling changes neither the hat matrix nor the least-squares residuals.
  for (int j = 0; j < m; ++j) {
    const double s = A.col(j).norm();
    if (!(s > 0)) return inf;
    A.col(j) /= s;
  }
  SmallQR qr;
  qr.compute(A, m, false);
  for (int j = 0; j < m; ++j)
    if (!(std::abs(qr.diag(j)) > 1e-12)) return inf;
  // The lower degree's fit: the leading ml columns' least-squares solution, from the same R.
  Eigen::VectorXd rl;
  if (ml > 0) {
    Eigen::VectorXd qtb, cl;
    qr.apply_qt(b, qtb);
    qr.solve(qtb, ml, cl);
    rl = b - A.leftCols(ml) * cl;
  }
  // Hat matrix diagonal h_ii = |R^-T a_i|^2 (a_i row i of A); a left-out point's residual is
  // r_i / (1 - h_ii). R^T is lower triangular: the leading ml entries of R^-T a_i give the
  // lower degree's leverage.
  Eigen::VectorXd y(m);
  double press = 0, pressl = 0;
  for (int i = 0; i < k; ++i) {
    double lev = 0, levl = 0;
    for (int j = 0; j < m; ++j) {
      double s = A(i, j);
      for (int l = 0; l < j; ++l) s -= qr.r(l, j) * y[l];
      y[j] = s / qr.diag(j);
      lev += y[j] * y[j];
      if (j + 1 == ml) levl = lev;
    }
    if (!(lev < 1 - 1e-9)) return inf;  // a point only it fixes
    press += std::pow(r[i] / (1 - lev), 2);
    if (ml > 0) pressl = levl < 1 - 1e-9 ? pressl + std::pow(rl[i] / (1 - levl), 2) : inf;
  }
  if (ml > 0) *lower_press = std::sqrt(pressl);
  return std::sqrt(press);
}

LocalFit solve_height_fit(const Eigen::Vector3d& o, const Eigen::Vector3d& n, double h,
                          const Eigen::MatrixXd& P, const Eigen::VectorXd& w, int degree,
                          const FitOptions& opt, const Eigen::MatrixXd& Q,
                          const Eigen::VectorXd& wq, bool basic, const FitReference& ref, FitDesign* design) {
  LocalFit F;
  F.o = o;
  F.n = n;
  if (ref.quadric_ref) {
    F.t1 = ref.t1, F.t2 = ref.t2, F.quadric_ref = true;
    std::copy(ref.q, ref.q + 8, F.q);
  } else if (ref.k2 != 0) {
    F.t1 = ref.t1, F.t2 = ref.t2, F.k1 = ref.k1, F.k2 = ref.k2;
  } else {
    tangent_frame(n, F.t1, F.t2);
  }
  F.h = h;
  F.requested_degree = degree;
  F.points = static_cast<int>(P.rows());
  F.support_points = static_cast<int>(Q.rows());
  const int k = static_cast<int>(P.rows()) + static_cast<int>(Q.rows());
  const int mmax = fit_coefficients(degree);
  // Full-degree rows once; lower degrees use the leading columns.
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  weighted_design(F, P, w, Q, wq, degree, A, b);
  if (design) design->A = A, design->b = b;
  // Column scaling once: a column's norm does not depend on how many leading columns a solve
  // keeps. Solves that would include a zero column (nonzero <= j) fail, as rank deficient.
  Eigen::VectorXd scale(mmax);
  int nonzero = 0;
  for (; nonzero < mmax; ++nonzero) {
    const double s = A.col(nonzero).norm();
    if (!(s > 0)) break;
    scale[nonzero] = 1.0 / s;
    A.col(nonzero) *= scale[nonzero];
  }
  // The safeguard's truncated fits: one unpivoted Householder QR of the scaled columns gives
  // every leading-columns least-squares solution (truncate R and Q^T b), instead of one
  // pivoted QR per lower degree. Same solutions up to round-off (full column rank is checked
  // on R's diagonal, as the pivoted rank test would).
  SmallQR hqr;
  Eigen::VectorXd qtb, ct;
  bool have_hqr = false;
  for (int p = degree; p >= 1; --p) {
    const int m = fit_coefficients(p);
    if (k < m || m > nonzero) continue;
    Eigen::VectorXd c;
    double pivot = 0;
    if (!solve_scaled(A, m, b, scale, basic ? opt.support_condition : opt.rank_tol, c, &pivot, basic)) continue;
    bool ok = true;
    if (!basic && opt.safeguard && p >= 3 && k < opt.safeguard_skip * m) {
      if (!have_hqr) {
        hqr.compute(A, fit_coefficients(p - 1), false);
        hqr.apply_qt(b, qtb);
        have_hqr = true;
      }
      for (int d = p - 1; d >= 2 && ok; --d) {
        const int md = fit_coefficients(d);
        double rmax = 0, rmin = std::numeric_limits<double>::infinity();
        for (int j = 0; j < md; ++j)
          rmax = std::max(rmax, std::abs(hqr.diag(j))), rmin = std::min(rmin, std::abs(hqr.diag(j)));
        if (!(rmin > opt.rank_tol * rmax)) { ok = false; break; }
        hqr.solve(qtb, md, ct);
        ct.array() *= scale.head(md).array();
        if (!ct.allFinite()) { ok = false; break; }
        for (int j = fit_coefficients(d - 1); j < md; ++j) {
          const double diff = std::abs(c[j] - ct[j]);
          if (diff > opt.safeguard_tol && diff >= 1.05 * std::abs(ct[j])) { ok = false; break; }
        }
      }
    }
    if (!ok) continue;
    F.degree = p;
    F.c = c;
    F.pivot_ratio = pivot;
    F.residual = (b - A.leftCols(m) * (c.array() / scale.head(m).array()).matrix()).norm();
    return F;
  }
  F.degree = 0;
  F.c.resize(0);
  return F;
}

double fit_offset_limit(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                        const FitOptions& opt) {
  const double l0 = (b - a).norm(), l1 = (c - b).norm(), l2 = (a - c).norm();
  const double longest = std::max({l0, l1, l2}), shortest = std::min({l0, l1, l2});
  const double floor = shortest < opt.needle_short_edge * longest ? opt.min_offset_edge * longest : 0;
  return opt.max_offset * std::max(std::sqrt((b - a).cross(c - a).norm()), floor);
}

namespace {

/// The reference surface a fit was solved over (to refit over the same one).
FitReference reference_of(const LocalFit& fit) {
  FitReference r;
  r.t1 = fit.t1, r.t2 = fit.t2, r.k1 = fit.k1, r.k2 = fit.k2;
  r.quadric_ref = fit.quadric_ref;
  std::copy(fit.q, fit.q + 8, r.q);
  return r;
}

/// The fit moves no point of its wedge's faces further than fit_offset_limit (about half an
/// edge): beyond that it extrapolates, not approximates.
/// The move of x is about |height(u, v) - z| at x's frame coordinates (u, v, z), taken affine
/// over a face (exact over the tangent plane; off by O(k h^2) over a reference torus, well
/// inside the limit).
bool fit_is_sane(const Mesh& mesh, const Wedges& W, int w, const LocalFit& fit, const FitOptions& opt) {
  if (!fit.c.allFinite()) return false;
  if (fit.identity) return true;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const double limit = fit_offset_limit(a, b, c, opt);
    const Eigen::Vector3d ua = fit.coords(a), ub = fit.coords(b) - ua, uc = fit.coords(c) - ua;
    for (int j = 0; j <= 4; ++j)
      for (int k = 0; j + k <= 4; ++k) {
        if (fit.exact) {  // no height function: the move itself
          const Eigen::Vector3d x = a + (j / 4.0) * (b - a) + (k / 4.0) * (c - a);
          if (!((fit.project(x) - x).norm() <= limit)) return false;
          continue;
        }
        const Eigen::Vector3d x = ua + (j / 4.0) * ub + (k / 4.0) * uc;
        if (!(std::abs(fit.height(x[0], x[1]) - x[2]) <= limit)) return false;
      }
  }
  return true;
}

}  // namespace

LocalFit fit_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                   const SupportPoints* support, const std::vector<int>& support_start,
                   const std::vector<int>& support_index, const FitOptions& opt) {
  FitScratch scratch;
  return fit_wedge(mesh, T, W, w, p, support, support_start, support_index, opt, scratch);
}

LocalFit fit_wedge_unchecked(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                             const SupportPoints* support, const std::vector<int>& support_start,
                             const std::vector<int>& support_index, const FitOptions& opt) {
  FitScratch scratch;
  return fit_wedge_unchecked(mesh, T, W, w, p, support, support_start, support_index, opt, scratch);
}

double wedge_turn_deg(const Mesh& mesh, const Wedges& W, int w, const Eigen::Vector3d& n) {
  double c = 1;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const Eigen::Vector3d m = face_normal(mesh, W.wedge_faces[i]);
    if (m.norm() > 0) c = std::min(c, m.normalized().dot(n));
  }
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

namespace {

/// Wedge w's exact quadric (wedge_exact_quadric) or plane (wedge_plane, planes true) as a fit
/// (exact false where it has none), in the frame of its height fit `fit` (vertex, scale h), the
/// normal turned to the surface's on the same side. Remembered in scratch.no_exact_surface when
/// there is none.
LocalFit exact_fit(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p, const FitOptions& opt,
                   FitScratch& scratch, const LocalFit& fit, bool planes) {
  const char bit = planes ? 2 : 1;
  char* none = scratch.no_exact_surface ? &(*scratch.no_exact_surface)[w] : nullptr;
  if (none && (*none & bit)) return LocalFit();
  ExactQuadric Q = planes ? wedge_plane(mesh, W, w, opt.exact) : wedge_exact_quadric(mesh, T, W, w, opt.exact, scratch.stencil);
  if (!Q.valid) {
    if (none) *none |= bit;
    return LocalFit();
  }
  return exact_surface_fit(std::make_shared<const ExactQuadric>(std::move(Q)), fit, p);
}

}  // namespace

LocalFit fit_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                   const SupportPoints* support, const std::vector<int>& support_start,
                   const std::vector<int>& support_index, const FitOptions& opt, FitScratch& scratch) {
  if (W.is_cone(W.wedge_vertex[w])) {  // no polynomial fits a cone's apex: a cone model does
    LocalFit apex = fit_apex(mesh, T, W, w, opt);
    apex.requested_degree = p;
    if (apex.apex) apex.degree = p;
    return apex;
  }
  LocalFit fit = fit_wedge_unchecked(mesh, T, W, w, p, support, support_start, support_index, opt, scratch);
  // The exact quadric, where the wedge's faces turn enough for the height polynomial to miss
  // (on finer meshes it fits to rounding too, and the quadric test would only cost time), and
  // on features, whose curves are where two exact sides cross (place_nodes.cpp).
  if (opt.exact_quadrics && p > 1 && (W.one_sided(w) || wedge_turn_deg(mesh, W, w, fit.n) > opt.exact.min_turn_deg)) {
    LocalFit exact = exact_fit(mesh, T, W, w, p, opt, scratch, fit, false);
    if (exact.exact && fit_is_sane(mesh, W, w, exact, opt)) return exact;
  }
  // A flat fan is on its plane, wherever its stencil reaches (a plane's first row beside a
  // fillet, whose height fit bends toward the fillet).
  if (opt.exact_quadrics && p > 1) {
    LocalFit plane = exact_fit(mesh, T, W, w, p, opt, scratch, fit, true);
    if (plane.exact) return plane;
  }
  if (fit_is_sane(mesh, W, w, fit, opt)) return fit;
  LocalFit low;
  if (p > 1) {
    low = fit_wedge(mesh, T, W, w, std::min(p - 1, std::max(fit.degree, 1)), support, support_start, support_index,
                    opt, scratch);
  } else {
    low = fit;
    low.identity = true;  // nothing sane: the corner keeps the straight triangles
    low.degree = 0;
  }
  low.requested_degree = p;
  return low;
}

namespace {

/// Whether the fit over the quadric reference (fq) beats the other one (f) on the same points.
bool better_quadric(const LocalFit& fq, const LocalFit& f, const Eigen::MatrixXd& P, const Eigen::VectorXd& w,
                    const FitOptions& opt, const FitDesign& dq, const FitDesign& df) {
  if (!opt.quadric_by_leave_one_out) return fq.residual < opt.quadric_gain * f.residual;
  return leave_one_out_residual(fq, P, w, 0, nullptr, &dq) <
         opt.quadric_loo_gain * leave_one_out_residual(f, P, w, 0, nullptr, &df);
}

}  // namespace

LocalFit reference_fit(const Eigen::Vector3d& o, const Eigen::Vector3d& n0, double h, const Eigen::MatrixXd& P,
                       const Eigen::VectorXd& wt, int p, const FitOptions& opt) {
  // The reference surface is set up in the tilt-corrected normal's frame: a tilted torus
  // leaves an O(tilt) residual with every power of u in it.
  Eigen::Vector3d nr = n0;
  FitReference ref = reference_surface(o, n0, P, wt, &nr);
  if (ref.k2 == 0) nr = n0;
  // The quadric reference where the data say it fits better (the weighted residual of the
  // whole fit, same points and weights): exact on quadrics, whose curvature varies along
  // the stencil, where the torus is exact only on spheres, cylinders and tori. Only then are
  // the torus fit's rows kept, for the comparison.
  const FitReference qr = opt.reference_quadric ? quadric_reference(o, nr, P, wt) : FitReference();
  const bool try_quadric = qr.quadric_ref && qr.residual < opt.quadric_gain * ref.residual;
  FitDesign dt, dq;
  LocalFit trial = solve_height_fit(o, nr, h, P, wt, p, opt, Eigen::MatrixXd(), Eigen::VectorXd(), false, ref,
                                    try_quadric ? &dt : nullptr);
  if (try_quadric) {
    LocalFit tq = solve_height_fit(o, nr, h, P, wt, p, opt, Eigen::MatrixXd(), Eigen::VectorXd(), false, qr, &dq);
    if (tq.degree == p && tq.pivot_ratio >= opt.support_condition &&
        (trial.degree < p || better_quadric(tq, trial, P, wt, opt, dq, dt))) {
      trial = std::move(tq);
      ref = qr;
    }
  }
  if ((ref.k2 != 0 || ref.quadric_ref) && (trial.degree < p || trial.pivot_ratio < opt.support_condition)) {
    // Short or ill-posed over the reference: what follows (degree fallbacks, support points)
    // is built for tangent-plane fits.
    trial = solve_height_fit(o, n0, h, P, wt, p, opt);
  }
  return trial;
}

namespace {

/// A one-sided wedge's plane fit (in its refined normal's frame) replaced by the fit over its
/// stencil's quadric where that fits the data much better (quadric_gain) and moves no point of
/// the wedge's faces (edge midpoints, centroids) by more than one_sided_quadric_gap x h: a
/// half-disc of data leaves the quadric free on the open side, and there it can bend away.
LocalFit one_sided_quadric_fit(const Mesh& mesh, const Wedges& W, int w, const Eigen::MatrixXd& P,
                               const Eigen::VectorXd& wt, double h, int p, const FitOptions& opt, LocalFit plane,
                               const FitDesign& plane_design, bool& gate_refused) {
  const FitReference qr = quadric_reference(plane.o, plane.n, P, wt);
  if (!qr.quadric_ref) return plane;
  FitDesign dq;
  LocalFit fq = solve_height_fit(plane.o, plane.n, h, P, wt, p, opt, Eigen::MatrixXd(), Eigen::VectorXd(), false, qr, &dq);
  if (fq.degree != p || fq.pivot_ratio < opt.support_condition || !better_quadric(fq, plane, P, wt, opt, dq, plane_design))
    return plane;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    for (const Eigen::Vector3d& x : {Eigen::Vector3d((a + b) / 2), Eigen::Vector3d((b + c) / 2),
                                     Eigen::Vector3d((a + c) / 2), Eigen::Vector3d((a + b + c) / 3)})
      if ((fq.project(x) - plane.project(x)).norm() > opt.one_sided_quadric_gap * h) {
        gate_refused = true;
        return plane;
      }
  }
  return fq;
}

}  // namespace

LocalFit fit_wedge_unchecked(const Mesh& mesh, const Topology& T, const Wedges& W, int w, int p,
                             const SupportPoints* support, const std::vector<int>& support_start,
                             const std::vector<int>& support_index, const FitOptions& opt,
                             FitScratch& scratch) {
  const int v = W.wedge_vertex[w];
  const Eigen::Vector3d o = mesh.V.row(v).transpose();
  // Area-weighted normal and mean incident edge length of the wedge.
  Eigen::Vector3d n0 = Eigen::Vector3d::Zero();
  double hsum = 0;
  int hcount = 0;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    int j = 0;
    while (mesh.F(f, j) != v) ++j;
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, (j + 1) % 3)).transpose() - o;
    const Eigen::Vector3d c = mesh.V.row(mesh.F(f, (j + 2) % 3)).transpose() - o;
    n0 += a.cross(c);
    hsum += a.norm() + c.norm();
    hcount += 2;
  }
  const double h = hcount ? std::max(hsum / hcount, 1e-300) : 1.0;
  if (n0.norm() > 0) n0.normalize();
  else n0 = Eigen::Vector3d::UnitZ();

  const int m = fit_coefficients(p);
  const bool one_sided = W.one_sided(w);
  // A vertex on an open boundary has one wedge but, like a one-sided one, a half disc of rings.
  bool half_disc = one_sided;
  for (auto [e, end] = T.edges_of(v); e != end && !half_disc; ++e) half_disc = T.edge_faces[*e].size() == 1;
  const int need = static_cast<int>(std::ceil((half_disc ? opt.points_per_coef_one_sided : opt.points_per_coef) * m));
  StencilOptions so;
  so.min_rings = 1;
  so.max_rings = opt.max_rings;
  so.target_points = need + 1;
  so.max_points = opt.max_points;
  Stencil S = grow_stencil(mesh, T, W, w, so, scratch.stencil);
  std::vector<int>& pts = scratch.pts;
  Eigen::MatrixXd P;
  Eigen::VectorXd dist, wt;
  double sigma = 0;
  auto gauss = [&](double d) { return std::exp(-d * d / (2 * sigma * sigma)); };
  auto face_normal = [&](int f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)),
                          c = mesh.V.row(mesh.F(f, 2));
    Eigen::Vector3d nf = (b - a).cross(c - a);
    const double l = nf.norm();
    return l > 0 ? Eigen::Vector3d(nf / l) : Eigen::Vector3d::Zero();
  };
  // Rank-deficient point sets get more rings before the degree is lowered: a one-sided stencil
  // on a structured grid has only p rows of vertices for degree p, and a pole fan's one ring is
  // one circle, however many points it has (so past max_points: a uv sphere's 160-triangle
  // pole fan fitted at degree 2 put its P4 nodes 1.6e-4 off, 6x below linear).
  LocalFit fit;
  int k = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (attempt > 0) {
      if (fit.degree >= p || S.rings >= opt.max_rings) break;
      so.min_rings = S.rings + 1;  // one more ring
      Stencil grown = grow_stencil(mesh, T, W, w, so, scratch.stencil);
      if (grown.vertices.size() == S.vertices.size()) break;
      S = std::move(grown);
    }
    // Normal cone: keep vertices seen by at least one region face facing like n0.
    StampSet& seen = scratch.seen;  // per attempt
    seen.clear();
    for (int f : S.faces)
      if (face_normal(f).dot(n0) > opt.normal_cone)
        for (int j = 0; j < 3; ++j) seen.insert(mesh.F(f, j));
    pts.clear();
    for (size_t i = 1; i < S.vertices.size(); ++i)
      if (seen.contains(S.vertices[i])) pts.push_back(S.vertices[i]);
    k = static_cast<int>(pts.size());
    P.resize(k, 3);
    dist.resize(k);
    for (int i = 0; i < k; ++i) {
      P.row(i) = mesh.V.row(pts[i]);
      dist[i] = (P.row(i).transpose() - o).norm();
    }
    // Weights.
    wt.resize(k);
    sigma = opt.sigma_factor * h;
    if (k > 0) {
      // The min(k, need)-th smallest distance (an order statistic: no full sort needed).
      std::vector<double>& sd = scratch.sorted;
      sd.assign(dist.data(), dist.data() + k);
      const int nth = std::min(k, need) - 1;
      std::nth_element(sd.begin(), sd.begin() + nth, sd.end());
      sigma = std::max(sigma, opt.sigma_reach * sd[nth]);
    }
    if (opt.weight == WeightKind::Gaussian) {
      for (int i = 0; i < k; ++i) wt[i] = gauss(dist[i]);
    } else {
      double mean2 = k ? dist.squaredNorm() / k : 1.0;
      for (int i = 0; i < k; ++i) wt[i] = std::pow(dist[i] * dist[i] / mean2 + 0.01, -0.5 * p);
    }

    // One-sided wedges fit over the plane (reference_torus), but the agreement pass offers them
    // their own torus or quadric too (FitScratch::one_sided_torus).
    const bool torus_candidate = one_sided && scratch.one_sided_torus;
    const bool use_reference =
        opt.reference_torus && (!one_sided || torus_candidate) && k >= opt.reference_min_points;
    LocalFit trial = use_reference ? reference_fit(o, n0, h, P, wt, p, opt) : solve_height_fit(o, n0, h, P, wt, p, opt);
    // One-sided wedges (a vertex on a feature) have an area-weighted normal biased at O(h):
    // those refit in the frame of the first fit's normal.
    // Only well-posed first fits (degree kept, pivots not tiny) give a trustworthy gradient.
    const bool well_posed = trial.degree == p && trial.pivot_ratio >= opt.support_condition;
    if ((opt.refine_normal || (one_sided && opt.refine_one_sided && well_posed)) && trial.degree >= 1 &&
        !torus_candidate) {
      Eigen::Vector3d n1 = trial.n - trial.c[0] * trial.t1 - trial.c[1] * trial.t2;
      if (n1.norm() > 0 && n1.normalized().dot(n0) > 0.5) {
        n1.normalize();
        FitDesign design;
        trial = solve_height_fit(o, n1, h, P, wt, p, opt, Eigen::MatrixXd(), Eigen::VectorXd(), false, FitReference(),
                                 &design);
        if (one_sided && opt.one_sided_quadric && trial.degree == p && k >= opt.reference_min_points) {
          if (S.rings < opt.max_rings || opt.one_sided_quadric_in_bands)
            trial = one_sided_quadric_fit(mesh, W, w, P, wt, h, p, opt, std::move(trial), design,
                                          scratch.quadric_gate_refused);
          else
            scratch.quadric_gate_refused = true;
        }
      }
    }
    trial.rings = S.rings;
    if (attempt == 0 || trial.degree > fit.degree) fit = trial;
  }

  if (scratch.compare_with_degree_4 && p > 4 && fit.degree == p && !fit.identity) {
    double low = 0;
    const double high = leave_one_out_residual(fit, P, wt, 4, &low);
    scratch.loo_ratio = high / low;
  }
  const bool short_of_vertices = fit.degree < p || fit.pivot_ratio < opt.support_condition;
  // Ill-conditioned fits (vertices on a few lines, as on the long strips of CAD exports)
  // extrapolate wildly at high degree: they fall back to a low degree, on the smaller stencil
  // that degree needs.
  const bool ill = fit.degree >= 1 && fit.pivot_ratio < opt.support_condition;
  if (ill && p > opt.short_fit_degree) {
    LocalFit low = fit_wedge(mesh, T, W, w, opt.short_fit_degree, support, support_start, support_index, opt, scratch);
    low.requested_degree = p;
    return low;
  }
  const int pd = p;
  const bool have_support = support && !support_start.empty();
  if (ill && !have_support) {
    // No samples to decide the open directions: take the minimum-norm fit (no curvature
    // along directions the vertices leave open).
    LocalFit basic = solve_height_fit(o, fit.n, h, P, wt, p, opt, Eigen::MatrixXd(), Eigen::VectorXd(), true, reference_of(fit));
    basic.rings = fit.rings;
    return basic;
  }
  if (support && (opt.support_everywhere || short_of_vertices) && !support_start.empty()) {
    const double R = k ? dist.maxCoeff() : 3 * h;
    std::vector<int> sel;
    for (int f : S.faces) {
      if (face_normal(f).dot(fit.n) <= opt.normal_cone) continue;
      for (int i = support_start[f]; i < support_start[f + 1]; ++i) {
        const int s = support_index[i];
        if ((support->P.row(s).transpose() - o).norm() <= R) sel.push_back(s);
      }
    }
    if (!sel.empty()) {
      const int ns = static_cast<int>(sel.size());
      Eigen::MatrixXd Q(ns, 3);
      Eigen::VectorXd wq(ns);
      for (int i = 0; i < ns; ++i) {
        Q.row(i) = support->P.row(sel[i]);
        const double d = (Q.row(i).transpose() - o).norm();
        wq[i] = opt.support_weight * (opt.weight == WeightKind::Gaussian ? gauss(d) : 1.0);
      }
      // Lift the facet samples onto the basic vertex fit: full degree where the vertices
      // determine it, zero coefficients for the columns they leave (nearly) open. Where the
      // vertex fit is well posed the lifted samples lie on it and the final fit equals it.
      if (opt.support_lift) {
        const LocalFit basic =
            solve_height_fit(o, fit.n, h, P, wt, pd, opt, Eigen::MatrixXd(), Eigen::VectorXd(), true, reference_of(fit));
        for (int i = 0; i < ns; ++i) Q.row(i) = basic.project(Q.row(i).transpose()).transpose();
      }
      LocalFit fs = solve_height_fit(o, fit.n, h, P, wt, pd, opt, Q, wq, false, reference_of(fit));
      fs.requested_degree = p;
      if (fs.degree >= fit.degree) {
        fs.rings = S.rings;
        fit = fs;
      }
    }
  }
  return fit;
}

std::vector<int> feature_ring_distance(const Topology& T, const Wedges& W) {
  const int nv = static_cast<int>(W.vertex_wedge_start.size()) - 1;
  std::vector<int> rings(nv, std::numeric_limits<int>::max());
  std::vector<int> queue;
  for (int v = 0; v < nv; ++v) {
    bool feature = W.vertex_wedges(v) > 1;
    for (auto [e, end] = T.edges_of(v); e != end && !feature; ++e) feature = T.edge_faces[*e].size() != 2;
    if (feature) {
      rings[v] = 0;
      queue.push_back(v);
    }
  }
  for (size_t i = 0; i < queue.size(); ++i)  // breadth first: each vertex is queued once
    for (auto [e, end] = T.edges_of(queue[i]); e != end; ++e) {
      const int u = T.other(*e, queue[i]);
      if (rings[u] == std::numeric_limits<int>::max()) {
        rings[u] = rings[queue[i]] + 1;
        queue.push_back(u);
      }
    }
  return rings;
}

namespace {

/// Spreads the low 21 bits of x to every third bit.
std::uint64_t spread3(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

/// The wedges sorted by the Morton (Z-order) code of their vertex (ties: by index).
std::vector<int> morton_order(const Mesh& mesh, const Wedges& W) {
  const int nw = W.num_wedges();
  std::vector<std::pair<std::uint64_t, int>> key(nw);
  const Eigen::RowVector3d lo = mesh.V.colwise().minCoeff(), hi = mesh.V.colwise().maxCoeff();
  const double ext = (hi - lo).maxCoeff();
  const double scale = ext > 0 && std::isfinite(ext) ? ((1 << 21) - 1) / ext : 0.0;
  for (int w = 0; w < nw; ++w) {
    const int v = W.wedge_vertex[w];
    std::uint64_t code = 0;
    for (int d = 0; d < 3; ++d) {
      const double q = (mesh.V(v, d) - lo[d]) * scale;
      const std::uint64_t c = q > 0 ? static_cast<std::uint64_t>(std::min(q, double((1 << 21) - 1))) : 0;
      code |= spread3(c) << d;
    }
    key[w] = {code, w};
  }
  std::sort(key.begin(), key.end());
  std::vector<int> order(nw);
  for (int i = 0; i < nw; ++i) order[i] = key[i].second;
  return order;
}

/// The degree wedge w is fitted at where the fits have degree p (feature_fit_degree at features).
int wedge_degree(const Wedges& W, int w, int p, const FitOptions& opt) {
  return W.one_sided(w) ? feature_fit_degree(p, opt) : p;
}

/// Largest distance, at the edge midpoints and centroids of wedge w's faces, between fit F and
/// the fits of those faces' corners whose wedges are two-sided; -1 when no corner is.
double disagreement(const Mesh& mesh, const Wedges& W, int w, const LocalFit& F, const std::vector<LocalFit>& fits) {
  double worst = -1;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    for (int j = 0; j < 3; ++j) {
      const int other = W.corner_wedge(f, j);
      if (other == w || W.one_sided(other)) continue;
      for (const Eigen::Vector3d& x : {Eigen::Vector3d((a + b) / 2), Eigen::Vector3d((b + c) / 2),
                                       Eigen::Vector3d((a + c) / 2), Eigen::Vector3d((a + b + c) / 3)}) {
        const Eigen::Vector3d y = F.project(x);
        worst = std::max(worst, (fits[other].project(y) - y).norm());
      }
    }
  }
  return worst;
}

/// FitOptions::one_sided_quadric_agreement: one-sided wedges refit with the quadric's gates open
/// (where the first pass met one) and over their half disc's torus (reference_fit); the candidate
/// that agrees best with the two-sided neighbours' fits is kept where it agrees much better than
/// the wedge's fit. Only one-sided fits change and only two-sided ones are read, so the order
/// does not matter. gate_refused[w]: the first pass met a gate on wedge w. no_exact_surface: the
/// first pass's memo of exact tests that found nothing (FitScratch).
long long adopt_agreeing_fits(const Mesh& mesh, const Topology& T, const Wedges& W, int p,
                              const SupportPoints* support, const std::vector<int>& sstart,
                              const std::vector<int>& sindex, const FitOptions& opt,
                              const std::vector<char>& gate_refused, std::vector<char>& no_exact_surface,
                              std::vector<LocalFit>& fits) {
  if (!opt.one_sided_quadric || !(opt.one_sided_quadric_agreement > 0)) return 0;
  FitOptions open = opt;
  open.one_sided_quadric_gap = std::numeric_limits<double>::infinity();
  open.one_sided_quadric_in_bands = true;
  const int nw = W.num_wedges();
  std::atomic<long long> adopted{0};
  tbb::enumerable_thread_specific<FitScratch> scratch;
  tbb::parallel_for(tbb::blocked_range<int>(0, nw, 16), [&](const tbb::blocked_range<int>& r) {
    FitScratch& s = scratch.local();
    s.no_exact_surface = &no_exact_surface;
    for (int w = r.begin(); w < r.end(); ++w) {
      const int d = wedge_degree(W, w, p, opt);
      const bool quadric_candidate = gate_refused[w] && !fits[w].quadric_ref && fits[w].degree == d;
      if (!W.one_sided(w) || fits[w].identity || fits[w].exact || !(quadric_candidate || opt.one_sided_torus)) continue;
      const double current = disagreement(mesh, W, w, fits[w], fits);
      if (!(current > 1e-6 * fits[w].h)) continue;  // agrees to round-off already
      double best = opt.one_sided_quadric_agreement * current;
      LocalFit chosen;
      auto consider = [&](LocalFit q) {
        if (q.degree != d || !(q.quadric_ref || q.k2 != 0)) return;
        const double off = disagreement(mesh, W, w, q, fits);
        if (off < best) best = off, chosen = std::move(q);
      };
      if (quadric_candidate) consider(fit_wedge(mesh, T, W, w, d, support, sstart, sindex, open, s));
      if (opt.one_sided_torus) {
        s.one_sided_torus = true;
        consider(fit_wedge(mesh, T, W, w, d, support, sstart, sindex, opt, s));
        s.one_sided_torus = false;
      }
      if (chosen.degree == d) {
        fits[w] = std::move(chosen);
        ++adopted;
      }
    }
  });
  return adopted;
}

/// FitOptions::elevated_degree: refits the candidate degree-4 wedges at that degree, unless the
/// median candidate turns by at most exact.min_turn_deg (a fine mesh, fitted to rounding at degree
/// 4), or the median of a sample of them (elevated_probes) does not predict its points better by
/// elevated_gain (noise or rounding, not truncation, sets degree 4's residual). Why per mesh, not
/// per wedge: a bumpy sphere's flatter wedges kept degree 4 next to degree-6 neighbours, P4 2.5e-8
/// -> 4.7e-7 (2.98e-7 with degree 4 everywhere).
void elevate_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const SupportPoints* support,
                  const std::vector<int>& sstart, const std::vector<int>& sindex, const FitOptions& opt,
                  std::vector<LocalFit>& fits) {
  if (opt.elevated_degree <= 4) return;
  const std::vector<int> rings = feature_ring_distance(T, W);
  std::vector<int> candidates;
  std::vector<double> turns;
  for (int w = 0; w < W.num_wedges(); ++w) {
    const LocalFit& f = fits[w];
    if (W.one_sided(w) || rings[W.wedge_vertex[w]] < opt.elevated_feature_rings || f.degree != 4 || f.exact ||
        f.apex || f.identity)
      continue;
    candidates.push_back(w);
    turns.push_back(wedge_turn_deg(mesh, W, w, f.n));
  }
  if (candidates.empty()) return;
  const auto median = [](std::vector<double> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  if (!(median(turns) > opt.exact.min_turn_deg)) return;
  // The probes (every stride-th candidate) keep their refits until the gain is known; the rest
  // go straight to their slots.
  const size_t n = candidates.size();
  const size_t stride = std::max<size_t>(1, n / std::max(1, opt.elevated_probes));
  tbb::enumerable_thread_specific<FitScratch> scratch;
  const auto refit = [&](size_t i, double& ratio) {
    FitScratch& s = scratch.local();
    const int w = candidates[i];
    // Unchecked: no exact surface to look for again on the larger stencil.
    constexpr double none = std::numeric_limits<double>::infinity();
    s.compare_with_degree_4 = true;
    s.loo_ratio = none;
    LocalFit high = fit_wedge_unchecked(mesh, T, W, w, opt.elevated_degree, support, sstart, sindex, opt, s);
    s.compare_with_degree_4 = false;
    ratio = high.degree == opt.elevated_degree && s.loo_ratio < none ? s.loo_ratio : none;  // NaN: none
    return high;
  };
  const auto keep = [&](size_t i, LocalFit&& high, double ratio) {
    const int w = candidates[i];
    if (ratio < 1 && high.pivot_ratio >= opt.high_degree_condition && fit_is_sane(mesh, W, w, high, opt))
      fits[w] = std::move(high);
  };
  const size_t np = (n + stride - 1) / stride;
  std::vector<LocalFit> probed(np);
  std::vector<double> probe_ratio(np);
  tbb::parallel_for(size_t(0), np, [&](size_t j) { probed[j] = refit(j * stride, probe_ratio[j]); });
  if (!(median(probe_ratio) < opt.elevated_gain)) return;
  for (size_t j = 0; j < np; ++j) keep(j * stride, std::move(probed[j]), probe_ratio[j]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      if (i % stride == 0) continue;  // probed
      double ratio = 0;
      LocalFit high = refit(i, ratio);
      keep(i, std::move(high), ratio);
    }
  });
}

}  // namespace

FitResult fit_wedges(const Mesh& mesh, const Topology& T, const Wedges& W, int p,
                     const SupportPoints* support, const FitOptions& opt) {
  const auto t0 = Clock::now();
  FitResult R;
  const int nw = W.num_wedges();
  R.fits.resize(nw);
  std::vector<int> sstart, sindex;
  if (support && support->P.rows() > 0) {
    const int nf = mesh.num_faces();
    sstart.assign(nf + 1, 0);
    for (Eigen::Index s = 0; s < support->face.size(); ++s) ++sstart[support->face[s] + 1];
    for (int f = 0; f < nf; ++f) sstart[f + 1] += sstart[f];
    sindex.resize(sstart[nf]);
    std::vector<int> fill(sstart.begin(), sstart.end() - 1);
    for (Eigen::Index s = 0; s < support->face.size(); ++s) sindex[fill[support->face[s]]++] = static_cast<int>(s);
  }
  // Wedges in Morton order of their vertices: consecutive stencils overlap, so the mesh data
  // they read stays in cache (input numberings are often spatially random: the 200k-triangle
  // Gmsh sphere's neighbours are a median 11k indices apart). Each fit still lands in its own
  // slot, so the result does not depend on the order.
  const std::vector<int> order = morton_order(mesh, W);
  std::vector<char> gate_refused(nw, 0);
  std::vector<char> no_exact_surface(nw, 0);  // each wedge's slot written by the task fitting it
  tbb::enumerable_thread_specific<FitScratch> scratch;
  tbb::parallel_for(tbb::blocked_range<int>(0, nw, 64), [&](const tbb::blocked_range<int>& r) {
    FitScratch& s = scratch.local();
    s.no_exact_surface = &no_exact_surface;
    for (int i = r.begin(); i < r.end(); ++i) {
      const int w = order[i];
      s.quadric_gate_refused = false;
      R.fits[w] = fit_wedge(mesh, T, W, w, wedge_degree(W, w, p, opt), support, sstart, sindex, opt, s);
      // Fits above min_degree (P5, P6) that are barely determined, or lowered to min_degree or
      // below, refit at min_degree: on its smaller stencil (and reference).
      const LocalFit& hi = R.fits[w];
      if ((hi.degree > opt.min_degree && hi.pivot_ratio < opt.high_degree_condition) ||
          (hi.requested_degree > opt.min_degree && hi.degree <= opt.min_degree)) {
        LocalFit low = fit_wedge(mesh, T, W, w, opt.min_degree, support, sstart, sindex, opt, s);
        if (low.degree == opt.min_degree) {
          low.requested_degree = R.fits[w].requested_degree;
          R.fits[w] = std::move(low);
        }
      }
      gate_refused[w] = s.quadric_gate_refused;
    }
  });
  if (p == 4) elevate_fits(mesh, T, W, support, sstart, sindex, opt, R.fits);
  R.agreeing_fits =
      adopt_agreeing_fits(mesh, T, W, p, support, sstart, sindex, opt, gate_refused, no_exact_surface, R.fits);
  R.apex_fits = share_apex_fits(T, W, opt, R.fits);
  if (opt.exact_quadrics && p > 1) {
    R.shared_exact_fits = share_exact_fits(mesh, W, opt.exact, R.fits);
    R.shared_exact_fits += tangent_exact_fits(mesh, T, W, opt.exact, R.fits);
    R.refitted_surfaces = refit_shared_surfaces(mesh, W, opt.exact, R.fits);
  }
  int top = p;
  for (const auto& f : R.fits) top = std::max(top, f.degree);
  R.degree_histogram.assign(top + 1, 0);
  double pts = 0;
  for (const auto& f : R.fits) {
    ++R.degree_histogram[f.degree];
    if (f.degree < f.requested_degree) ++R.downgraded;
    if (f.support_points > 0) ++R.with_support;
    if (f.exact) ++R.exact_fits;
    if (f.degree > p && !f.exact) ++R.elevated_fits;
    pts += f.points;
  }
  R.mean_points = nw ? pts / nw : 0;
  R.seconds = seconds_since(t0);
  return R;
}

}  // namespace hocurve
