#include "engine/curving/exact_quadric.hpp"

#include "engine/curving/stencil.hpp"

#include <Eigen/Geometry>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>

namespace hocurve {

namespace {

using Coefficients = Eigen::Matrix<double, 14, 1>;

/// The quadric's 10 monomials, then the cyclide's |y|^2 y and |y|^4.
Coefficients monomials(const Eigen::Vector3d& y) {
  const double s = y.squaredNorm();
  Coefficients m;
  m << y[0] * y[0], y[1] * y[1], y[2] * y[2], y[0] * y[1], y[1] * y[2], y[2] * y[0], y[0], y[1], y[2], 1.0, s * y[0],
      s * y[1], s * y[2], s * s;
  return m;
}

}  // namespace

Eigen::Vector3d ExactQuadric::gradient(const Eigen::Vector3d& x) const {
  const Eigen::Vector3d y = (x - centre) / scale;
  const double s = y.squaredNorm();
  const Eigen::Vector3d quadric(2 * c[0] * y[0] + c[3] * y[1] + c[5] * y[2] + c[6],
                                2 * c[1] * y[1] + c[3] * y[0] + c[4] * y[2] + c[7],
                                2 * c[2] * y[2] + c[4] * y[1] + c[5] * y[0] + c[8]);
  // d(|y|^2 b.y) = 2 (b.y) y + |y|^2 b, d|y|^4 = 4 |y|^2 y.
  const Eigen::Vector3d b = c.segment<3>(10);
  return quadric + (2 * b.dot(y) + 4 * c[13] * s) * y + s * b;
}

double ExactQuadric::value(const Eigen::Vector3d& x) const { return c.dot(monomials((x - centre) / scale)); }

double ExactQuadric::distance(const Eigen::Vector3d& x) const {
  const double g = gradient(x).norm();
  return g > 0 ? std::abs(value(x)) / g * scale : std::numeric_limits<double>::infinity();
}

Eigen::Vector3d ExactQuadric::project(const Eigen::Vector3d& x) const {
  Eigen::Vector3d y = x;
  for (int it = 0; it < 20; ++it) {
    const Eigen::Vector3d g = gradient(y);
    const double g2 = g.squaredNorm();
    if (!(g2 > 0)) return x;
    const Eigen::Vector3d step = value(y) / g2 * scale * g;
    y -= step;
    if (step.norm() <= 1e-15 * scale) break;
  }
  return y.allFinite() ? y : x;
}

namespace {

/// Largest first-order distance (world units) of the points (rows of Y, coordinates divided by
/// scale) to the quadric c.
double max_distance(const Eigen::MatrixXd& Y, const Coefficients& c, double scale) {
  ExactQuadric Q;
  Q.c = c;
  double d = 0;
  for (Eigen::Index i = 0; i < Y.rows(); ++i) d = std::max(d, Q.distance(Y.row(i).transpose()) * scale);
  return std::isnan(d) ? std::numeric_limits<double>::infinity() : d;
}

/// Gradients (rows: d/dy0, d/dy1, d/dy2) of the 14 monomials at y (monomials()).
Eigen::Matrix<double, 3, 14> monomial_gradients(const Eigen::Vector3d& y) {
  Eigen::Matrix<double, 3, 14> G = Eigen::Matrix<double, 3, 14>::Zero();
  G(0, 0) = 2 * y[0], G(1, 1) = 2 * y[1], G(2, 2) = 2 * y[2];
  G(0, 3) = y[1], G(1, 3) = y[0], G(1, 4) = y[2], G(2, 4) = y[1], G(2, 5) = y[0], G(0, 5) = y[2];
  G(0, 6) = G(1, 7) = G(2, 8) = 1;
  // d(|y|^2 y_k) = 2 y_k y + |y|^2 e_k, d|y|^4 = 4 |y|^2 y.
  const double s = y.squaredNorm();
  for (int k = 0; k < 3; ++k) {
    G.col(10 + k) = 2 * y[k] * y;
    G(k, 10 + k) += s;
  }
  G.col(13) = 4 * s * y;
  return G;
}

/// Normal matrices over points (rows of U, scaled to the unit ball) of the first N monomials (M)
/// and of their gradients (G, only where a miss bound is tested), lower triangles. The first n < N
/// monomials' matrices are their leading blocks: one pass serves quadrics and cyclides.
template <int N>
struct ImplicitNormals {
  Eigen::Matrix<double, N, N> M = Eigen::Matrix<double, N, N>::Zero(), G = Eigen::Matrix<double, N, N>::Zero();
};

template <int N>
ImplicitNormals<N> implicit_normals(const Eigen::MatrixXd& U, bool gradients) {
  ImplicitNormals<N> S;
  for (Eigen::Index i = 0; i < U.rows(); ++i)
    S.M.template selfadjointView<Eigen::Lower>().rankUpdate(monomials(U.row(i).transpose()).template head<N>());
  if (gradients)
    for (Eigen::Index i = 0; i < U.rows(); ++i) {
      const Eigen::Matrix<double, 3, 14> Gi = monomial_gradients(U.row(i).transpose());
      for (int d = 0; d < 3; ++d)  // rank-1 updates of fixed size: a rank-3 update goes through GEMM
        S.G.template selfadjointView<Eigen::Lower>().rankUpdate(
            Eigen::Matrix<double, N, 1>(Gi.row(d).template head<N>().transpose()));
    }
  return S;
}

/// True when no surface of the first n monomials lies within b (scaled units) of every point. A
/// surface c within b has |q(y_i)| <= b |grad q(y_i)|, so c^T M c <= b^2 c^T G c; where M - b^2 G
/// is positive definite (with room for rounding), no c is: a Cholesky factor instead of the eigen
/// solve (scans' wedges and edges: none is exact).
template <int n, int N>
bool misses(const ImplicitNormals<N>& S, double b) {
  const Eigen::Matrix<double, n, n> M = S.M.template topLeftCorner<n, n>();
  Eigen::Matrix<double, n, n> D = M - b * b * S.G.template topLeftCorner<n, n>();
  D.diagonal().array() -= 1e-12 * M.trace();
  return Eigen::LLT<Eigen::Matrix<double, n, n>>(D).info() == Eigen::Success;
}

/// Q missed its points: no surface of its family is near them.
void set_missed(ExactQuadric& Q) {
  Q.max_residual = Q.runner_up = std::numeric_limits<double>::infinity();
  Q.missed = true;
}

/// Q's coefficients: the smallest eigenvector of the first n monomials' normal matrix (5x cheaper
/// than the SVD, once per wedge); the next one is the runner-up.
template <int n, int N>
void eigen_fit(const ImplicitNormals<N>& S, const Eigen::MatrixXd& U, ExactQuadric& Q) {
  const Eigen::Matrix<double, n, n> M = S.M.template topLeftCorner<n, n>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, n, n>> eig(M.template selfadjointView<Eigen::Lower>());
  if (eig.info() != Eigen::Success) return;
  Coefficients runner_up = Coefficients::Zero();
  Q.c.setZero();
  Q.c.template head<n>() = eig.eigenvectors().col(0);
  runner_up.template head<n>() = eig.eigenvectors().col(1);
  Q.max_residual = max_distance(U, Q.c, Q.scale);
  Q.runner_up = max_distance(U, runner_up, Q.scale);
  Q.valid = Q.c.allFinite() && std::isfinite(Q.max_residual);
}

/// The surface of the first N monomials through the points U (eigen_fit); with a finite miss_bound
/// (world units), Q.missed instead where none is within it of every point (misses).
template <int N>
void fit_implicit(const Eigen::MatrixXd& U, ExactQuadric& Q, double miss_bound) {
  const bool bounded = miss_bound < std::numeric_limits<double>::infinity();
  const ImplicitNormals<N> S = implicit_normals<N>(U, bounded);
  if (bounded && misses<N, N>(S, miss_bound / Q.scale)) return set_missed(Q);
  eigen_fit<N, N>(S, U, Q);
}

/// The points P relative to their centroid, which becomes Q's centre; their largest norm
/// becomes Q's scale.
Eigen::MatrixXd centred(const Eigen::MatrixXd& P, ExactQuadric& Q) {
  Q.centre = P.colwise().mean().transpose();
  Eigen::MatrixXd Y = P.rowwise() - Q.centre.transpose();
  Q.scale = Y.rowwise().norm().maxCoeff();
  return Y;
}

/// Points on a plane lie on every quadric containing it: the plane, where it fits (Y centred).
bool fit_plane(const Eigen::MatrixXd& Y, ExactQuadric& Q) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> cov(Y.transpose() * Y);
  const Eigen::Vector3d n = cov.eigenvectors().col(0);
  const double off = (Y * n).cwiseAbs().maxCoeff();
  if (!(cov.info() == Eigen::Success && off <= 1e-3 * Q.scale)) return false;
  Q.c.setZero();
  Q.c.segment<3>(6) = n;
  Q.max_residual = off;
  Q.runner_up = (Y * cov.eigenvectors().col(1)).cwiseAbs().maxCoeff();  // the best plane across it
  Q.valid = true;
  return true;
}

}  // namespace

ExactQuadric fit_exact_quadric(const Eigen::MatrixXd& P, bool planes, double miss_bound) {
  ExactQuadric Q;
  const int k = static_cast<int>(P.rows());
  if (k < 4) return Q;
  const Eigen::MatrixXd Y = centred(P, Q);
  if (!(Q.scale > 0)) return Q;
  if (planes && fit_plane(Y, Q)) return Q;
  if (k < 12) return Q;
  fit_implicit<10>(Y / Q.scale, Q, miss_bound);
  return Q;
}

namespace {

/// Largest miss of quadric c (normalised coordinates) on the points Y and the normals N at
/// points Z: a point's first-order distance, a normal's angle (sine) x scale, world units.
double max_miss(const Eigen::MatrixXd& Y, const Eigen::MatrixXd& Z, const Eigen::MatrixXd& N, const Coefficients& c,
                double scale) {
  double d = max_distance(Y, c, scale);
  for (Eigen::Index i = 0; i < Z.rows(); ++i) {
    const Eigen::Vector3d g = monomial_gradients(Z.row(i).transpose()) * c;
    const Eigen::Vector3d n = N.row(i).transpose();
    const double sine = g.cross(n).norm() / g.norm();
    d = std::max(d, std::isfinite(sine) ? sine * scale : std::numeric_limits<double>::infinity());
  }
  return d;
}

}  // namespace

namespace {

/// fit_tangent_quadric on the first N monomials (10: quadrics, 14: cyclides).
template <int N>
ExactQuadric fit_tangent(const Eigen::MatrixXd& P, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Nrm) {
  ExactQuadric Q;
  if (P.rows() < 4 || P.rows() + 2 * X.rows() < N + 2) return Q;
  const Eigen::MatrixXd Y = centred(P, Q) / Q.scale;
  if (!(Q.scale > 0)) return Q;
  const Eigen::MatrixXd Z = (X.rowwise() - Q.centre.transpose()) / Q.scale;
  Eigen::Matrix<double, N, N> M = Eigen::Matrix<double, N, N>::Zero();
  for (Eigen::Index i = 0; i < Y.rows(); ++i)
    M.template selfadjointView<Eigen::Lower>().rankUpdate(monomials(Y.row(i).transpose()).template head<N>());
  for (Eigen::Index i = 0; i < Z.rows(); ++i) {
    // The gradient has no part along the tangent plane of the given normal.
    const Eigen::Matrix<double, 3, N> G = monomial_gradients(Z.row(i).transpose()).template leftCols<N>();
    const Eigen::Vector3d n = Nrm.row(i).transpose().normalized(), t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    M.template selfadjointView<Eigen::Lower>().rankUpdate((t1.transpose() * G).transpose());
    M.template selfadjointView<Eigen::Lower>().rankUpdate((t2.transpose() * G).transpose());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(M.template selfadjointView<Eigen::Lower>());
  if (eig.info() != Eigen::Success) return Q;
  Coefficients runner_up = Coefficients::Zero();
  Q.c.setZero();
  Q.c.template head<N>() = eig.eigenvectors().col(0);
  runner_up.template head<N>() = eig.eigenvectors().col(1);
  Q.max_residual = max_miss(Y, Z, Nrm, Q.c, Q.scale);
  Q.runner_up = max_miss(Y, Z, Nrm, runner_up, Q.scale);
  Q.valid = Q.c.allFinite() && std::isfinite(Q.max_residual);
  return Q;
}

}  // namespace

ExactQuadric fit_tangent_quadric(const Eigen::MatrixXd& P, const Eigen::MatrixXd& X, const Eigen::MatrixXd& N) {
  return fit_tangent<10>(P, X, N);
}

ExactQuadric fit_tangent_cyclide(const Eigen::MatrixXd& P, const Eigen::MatrixXd& X, const Eigen::MatrixXd& N) {
  return fit_tangent<14>(P, X, N);
}

ExactQuadric fit_exact_sphere(const Eigen::MatrixXd& P) {
  ExactQuadric Q;
  if (P.rows() < 6) return Q;
  const Eigen::MatrixXd Y = centred(P, Q) / Q.scale;
  if (!(Q.scale > 0)) return Q;
  // The quadric's monomials with equal squares: |y|^2, y, 1.
  auto sphere_monomials = [](const Eigen::Vector3d& y) -> Eigen::Matrix<double, 5, 1> {
    return (Eigen::Matrix<double, 5, 1>() << y.squaredNorm(), y[0], y[1], y[2], 1.0).finished();
  };
  Eigen::Matrix<double, 5, 5> M = Eigen::Matrix<double, 5, 5>::Zero();
  for (Eigen::Index i = 0; i < Y.rows(); ++i)
    M.selfadjointView<Eigen::Lower>().rankUpdate(sphere_monomials(Y.row(i).transpose()));
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> eig(M.selfadjointView<Eigen::Lower>());
  if (eig.info() != Eigen::Success) return Q;
  auto coefficients = [](const Eigen::Matrix<double, 5, 1>& e) -> Coefficients {
    Coefficients c = Coefficients::Zero();
    c.head<3>().setConstant(e[0]);
    c.segment<4>(6) = e.tail<4>();
    return c / c.norm();
  };
  Q.c = coefficients(eig.eigenvectors().col(0));
  Q.max_residual = max_distance(Y, Q.c, Q.scale);
  Q.runner_up = max_distance(Y, coefficients(eig.eigenvectors().col(1)), Q.scale);
  Q.valid = Q.c.allFinite() && std::isfinite(Q.max_residual);
  return Q;
}

ExactQuadric fit_exact_cyclide(const Eigen::MatrixXd& P, double miss_bound) {
  ExactQuadric Q;
  if (P.rows() < 16) return Q;
  const Eigen::MatrixXd Y = centred(P, Q);
  if (Q.scale > 0) fit_implicit<14>(Y / Q.scale, Q, miss_bound);
  return Q;
}

double coordinate_rounding(const Mesh& mesh) {
  bool single = true;
  for (Eigen::Index i = 0; i < mesh.V.size() && single; ++i)
    single = static_cast<double>(static_cast<float>(mesh.V.data()[i])) == mesh.V.data()[i];
  if (single) return std::ldexp(1.0, -24);
  // Decimal text (OBJ, ASCII STL): the most significant digits a sampled coordinate needs to
  // come back exactly.
  int most = 1;
  const Eigen::Index n = mesh.V.size(), step = std::max<Eigen::Index>(1, n / 3000);
  char text[40];
  for (Eigen::Index i = 0; i < n && most < 17; i += step) {
    const double x = mesh.V.data()[i];
    int digits = most;
    for (; digits < 17; ++digits) {
      std::snprintf(text, sizeof text, "%.*e", digits - 1, x);
      if (std::strtod(text, nullptr) == x) break;
    }
    most = digits;
  }
  return std::max(0.5 * std::pow(10.0, 1 - most), std::numeric_limits<double>::epsilon());
}

namespace {

/// The quadric's symmetric 4 x 4 matrix: q(y) = (y, 1)^T A (y, 1).
Eigen::Matrix4d quadric_matrix(const ExactQuadric& Q) {
  const auto& c = Q.c;
  Eigen::Matrix4d A;
  A << c[0], c[3] / 2, c[5] / 2, c[6] / 2, c[3] / 2, c[1], c[4] / 2, c[7] / 2, c[5] / 2, c[4] / 2, c[2], c[8] / 2,
      c[6] / 2, c[7] / 2, c[8] / 2, c[9];
  return A;
}

}  // namespace

bool plane_pair(const ExactQuadric& Q) {
  if (Q.cyclide() || Q.plane()) return false;
  const Eigen::Matrix4d A = quadric_matrix(Q);
  Eigen::Vector4d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(A, Eigen::EigenvaluesOnly).eigenvalues().cwiseAbs();
  std::sort(ev.data(), ev.data() + 4);
  return ev[1] <= 1e-6 * ev[3];
}

bool round_primitive(const ExactQuadric& Q) {
  if (Q.cyclide() || Q.plane()) return false;
  const Eigen::Matrix4d M = quadric_matrix(Q);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M.topLeftCorner<3, 3>());
  const Eigen::Vector3d ev = es.eigenvalues();
  const double big = ev.cwiseAbs().maxCoeff(), tol = 1e-6 * big;
  auto equal = [&](int i, int j) { return std::abs(ev[i] - ev[j]) <= tol; };
  if (equal(0, 2)) return true;  // a sphere (a real one: the fit went through the points)
  // The odd eigenvalue out, the two equal ones the circular sections'.
  const int odd = equal(1, 2) ? 0 : equal(0, 1) ? 2 : -1;
  if (odd < 0) return false;
  if (std::abs(ev[odd]) <= tol)  // a cylinder, unless the axis has a linear term (a paraboloid)
    return std::abs(es.eigenvectors().col(odd).dot(M.block<3, 1>(0, 3))) <= tol;
  // A cone: the sections' and the axis's curvatures of opposite signs and an apex (M singular).
  const Eigen::Vector4d all = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(M, Eigen::EigenvaluesOnly).eigenvalues();
  return ev[odd] * ev[(odd + 1) % 3] < 0 && all.cwiseAbs().minCoeff() <= tol;
}

bool plane_sphere(const ExactQuadric& Q) { return Q.cyclide() && std::abs(Q.c[13]) <= 1e-10 * Q.c.norm(); }

bool reducible(const ExactQuadric& Q) { return plane_pair(Q) || plane_sphere(Q); }

bool determined(const ExactQuadric& Q, double tolerance, const ExactQuadricOptions& opt, double size) {
  const bool precise = tolerance <= opt.cyclide_precision * size;
  const double unique = !Q.cyclide() ? opt.unique : precise ? opt.unique_cyclide_precise : opt.unique_cyclide;
  return Q.valid && Q.max_residual <= tolerance && Q.runner_up >= unique * tolerance;
}

bool face_agrees(const Mesh& mesh, int f, const ExactQuadric& Q, const ExactQuadricOptions& opt, double& side) {
  const double min_cos = std::cos(opt.max_normal_angle_deg * std::numbers::pi / 180.0);
  const Eigen::Vector3d n = face_normal(mesh, f).normalized();
  for (int j = 0; j < 3; ++j) {
    const double c = n.dot(Q.gradient(mesh.V.row(mesh.F(f, j)).transpose()).normalized());
    if (side == 0) side = c > 0 ? 1 : -1;
    if (!(side * c >= min_cos)) return false;
  }
  return true;
}

namespace {

/// fit_exact_quadric (planes: a plane first), else with opt.cyclides fit_exact_cyclide (empty below
/// 16 points), both bounded by tolerance, from one pass over the points: the cyclides' monomials
/// include the quadrics', so where no cyclide is within tolerance (every wedge of a scan) no
/// quadric is either, and neither is fitted. Same results as the two fits in turn, 3% less time
/// on a scan (boot).
ExactQuadric fit_quadric_or_cyclide(const Eigen::MatrixXd& P, bool planes, double tolerance,
                                    const ExactQuadricOptions& opt) {
  ExactQuadric Q;
  const int k = static_cast<int>(P.rows());
  if (k < 4) return Q;
  const Eigen::MatrixXd Y = centred(P, Q);
  if (!(Q.scale > 0)) return ExactQuadric();
  const bool planar = planes && fit_plane(Y, Q);
  if (planar && determined(Q, tolerance, opt)) return Q;
  const bool quadric = !planar && k >= 12, cyclide = opt.cyclides && k >= 16;
  if (!quadric && !cyclide) return opt.cyclides ? ExactQuadric() : Q;
  const Eigen::MatrixXd U = Y / Q.scale;
  const double b = tolerance / Q.scale;
  const ImplicitNormals<14> S = implicit_normals<14>(U, true);
  ExactQuadric C;
  C.centre = Q.centre, C.scale = Q.scale;
  if (cyclide && misses<14, 14>(S, b)) {
    set_missed(C);
    return C;
  }
  if (quadric) {
    if (misses<10, 14>(S, b)) set_missed(Q);
    else eigen_fit<10, 14>(S, U, Q);
    if (determined(Q, tolerance, opt) || !opt.cyclides) return Q;
    if (!cyclide) return ExactQuadric();
  }
  eigen_fit<14, 14>(S, U, C);
  return C;
}

/// The quadric, else (opt.cyclides) the cyclide, through the vertices of `faces` (invalid unless
/// they lie on it within tolerance, it is determined, and it is regular at `ends`: a crease
/// between two planes lies on their product, singular along it). planes: a plane through them
/// is taken too. sphere: a sphere only (fit_exact_sphere). off_features: through the corners off
/// W's feature curves only, those on them within opt.clear_factor x the tolerance (invalid where
/// no corner is on one): a CAD kernel's curves between two faces are only within the file's
/// tolerance of them (screw.step: the slot's rims 12x the tolerance off the dome).
ExactQuadric fit_region(const Mesh& mesh, const std::vector<int>& faces, std::initializer_list<int> ends,
                        const ExactQuadricOptions& opt, bool planes = false, bool sphere = false,
                        const Wedges* off_features = nullptr) {
  const std::vector<int> verts = face_corners(mesh, faces.data(), faces.data() + faces.size());
  auto on_feature = [&](int v) { return off_features && off_features->vertex_wedges(v) > 1; };
  const long fitted = std::count_if(verts.begin(), verts.end(), [&](int v) { return !on_feature(v); });
  if (fitted < 4 || (off_features && fitted == static_cast<long>(verts.size()))) return ExactQuadric();
  Eigen::MatrixXd P(fitted, 3);
  double largest_norm = 0;
  for (size_t i = 0, k = 0; i < verts.size(); ++i) {
    largest_norm = std::max(largest_norm, mesh.V.row(verts[i]).norm());
    if (!on_feature(verts[i])) P.row(k++) = mesh.V.row(verts[i]);
  }
  const double tolerance = opt.relative_tolerance() * largest_norm;
  ExactQuadric Q = sphere ? fit_exact_sphere(P) : fit_quadric_or_cyclide(P, planes, tolerance, opt);
  Q.tolerance = tolerance;
  Q.valid = determined(Q, tolerance, opt, (P.colwise().maxCoeff() - P.colwise().minCoeff()).norm()) && !reducible(Q);
  for (int v : verts)
    if (on_feature(v) && !(Q.distance(mesh.V.row(v).transpose()) <= opt.clear_factor * tolerance)) Q.valid = false;
  double largest = 0;
  for (int v : verts) largest = std::max(largest, Q.gradient(mesh.V.row(v).transpose()).norm());
  for (int v : ends)
    if (!(Q.gradient(mesh.V.row(v).transpose()).norm() >= opt.min_gradient_ratio * largest)) Q.valid = false;
  return Q;
}

/// Largest distance between two corners of `faces`.
double fan_size(const Mesh& mesh, const std::vector<int>& faces) {
  const std::vector<int> verts = face_corners(mesh, faces.data(), faces.data() + faces.size());
  double size = 0;
  for (size_t i = 0; i < verts.size(); ++i)
    for (size_t j = 0; j < i; ++j) size = std::max(size, (mesh.V.row(verts[i]) - mesh.V.row(verts[j])).norm());
  return size;
}

/// v is an inner vertex: as many edges as faces round it (none on the boundary).
bool closed_fan(const Topology& T, int v) {
  const auto [fb, fe] = T.faces_of(v);
  const auto [eb, ee] = T.edges_of(v);
  return fe - fb == ee - eb;
}

/// Two faces of `faces` sharing an edge are coplanar (within 0.5 degrees).
bool has_coplanar_pair(const Mesh& mesh, const Topology& T, const std::vector<int>& faces) {
  for (int f : faces)
    for (int j = 0; j < 3; ++j)
      for (int g : T.edge_faces[T.FE(f, j)])
        if (g > f && std::find(faces.begin(), faces.end(), g) != faces.end() &&
            face_normal(mesh, f).normalized().dot(face_normal(mesh, g).normalized()) > std::cos(0.5 * std::numbers::pi / 180))
          return true;
  return false;
}

/// Q is a cyclide that misses some of its points: they lie on no cyclide, nor do more points
/// round them, and no larger region need be tried (scans' wedges, creases).
bool off_every_cyclide(const ExactQuadric& Q) {
  return (Q.cyclide() || Q.missed) && !(Q.max_residual <= Q.tolerance);
}

/// Per face of `faces`: 1 where its normal is within max_normal_angle_deg of the quadric's at its
/// corners, on the side of faces[0].
std::vector<char> agreeing(const Mesh& mesh, const ExactQuadric& Q, const std::vector<int>& faces,
                           const ExactQuadricOptions& opt) {
  std::vector<char> agree(faces.size(), 1);
  double side = 0;
  for (size_t i = 0; i < faces.size(); ++i) agree[i] = face_agrees(mesh, faces[i], Q, opt, side);
  return agree;
}

bool all_agree(const std::vector<char>& agree) { return std::count(agree.begin(), agree.end(), 0) == 0; }

/// True when the vertices on Q connected to v through mesh edges number at least
/// opt.region_points (the search stops at confirm_points), and every vertex met next to them off
/// Q is off by clear_factor x the tolerance: Q is one CAD face ending at a crease or a tangent
/// junction (past a junction the distance grows as the curvature jump x the distance squared),
/// not a smooth surface drifting off a quadric that fits it nearby (the distance grows gradually,
/// a few x per ring). Why: a coarse half sphere's 40-point stencils all cross its junction with
/// the cylinder, so none confirms its quadric.
bool region_ends_clearly(const Mesh& mesh, const Topology& T, const ExactQuadric& Q, int v,
                         const ExactQuadricOptions& opt, StencilScratch& scratch) {
  std::vector<int>& on = scratch.frontier;
  on.assign(1, v);
  scratch.vertices.clear();
  scratch.vertices.insert(v);
  for (size_t i = 0; i < on.size(); ++i) {
    if (static_cast<int>(on.size()) >= opt.confirm_points) return true;
    for (auto [b, e] = T.edges_of(on[i]); b != e; ++b) {
      const int u = T.other(*b, on[i]);
      if (!scratch.vertices.insert(u)) continue;
      const double d = Q.distance(mesh.V.row(u).transpose());
      if (d <= Q.tolerance)
        on.push_back(u);
      else if (!(d >= opt.clear_factor * Q.tolerance))
        return false;
    }
  }
  return static_cast<int>(on.size()) >= opt.region_points;
}

}  // namespace

ExactQuadric fan_sphere(const Mesh& mesh, const Topology& T, int v, const ExactQuadricOptions& opt) {
  ExactQuadric Q;
  if (!closed_fan(T, v)) return Q;
  const auto [b, e] = T.faces_of(v);
  const std::vector<int> fan(b, e);
  // Adjacent faces of a sphere are never coplanar; a cylinder's flat cap of two or more triangles
  // with no inner vertex has all its corners on its two rims, so on a sphere.
  if (has_coplanar_pair(mesh, T, fan)) return Q;
  Q = fit_region(mesh, fan, {v}, opt, false, true);
  Q.valid = Q.valid && Q.tolerance <= opt.fan_sphere_precision * fan_size(mesh, fan) && all_agree(agreeing(mesh, Q, fan, opt));
  return Q;
}

bool edge_on_exact_quadric(const Mesh& mesh, const Topology& T, int e, const std::vector<double>& face_angle,
                           const ExactQuadricOptions& opt, double min_wall_deg) {
  const auto& ef = T.edge_faces[e];
  if (ef.size() != 2) return false;
  // The region: face rings round e, not across edges turning much further than e, nor out of
  // `keep` (when given, per face of `from`).
  double wall = std::max(opt.wall_factor * face_angle[e] + 15.0, min_wall_deg);
  auto grow = [&](const std::vector<char>* keep, const std::vector<int>& from, int rings) {
    std::vector<int> faces(ef.begin(), ef.end());
    for (int step = 0, begin = 0; step < rings; ++step) {
      const int end = static_cast<int>(faces.size());
      for (int i = begin; i < end; ++i)
        for (int j = 0; j < 3; ++j) {
          const int g = T.FE(faces[i], j);
          if (T.edge_faces[g].size() != 2 || face_angle[g] > wall) continue;
          for (int f : T.edge_faces[g]) {
            if (keep) {
              const auto it = std::find(from.begin(), from.end(), f);
              if (it == from.end() || !(*keep)[it - from.begin()]) continue;
            }
            if (std::find(faces.begin(), faces.end(), f) == faces.end()) faces.push_back(f);
          }
        }
      begin = end;
    }
    return faces;
  };
  int rings = opt.rings;
  std::vector<int> region = grow(nullptr, {}, rings);
  // A region of flat faces only (every face with a coplanar neighbour) is a prism's side, two
  // triangles per flat face, their corners on a cylinder too. Gmsh meshes some strips of a
  // cylinder between two rulings (its seam, beside a junction): those are flat too, but not all.
  auto flat = [&](int f) {
    for (int j = 0; j < 3; ++j)
      if (const int g = T.FE(f, j); T.edge_faces[g].size() == 2 && face_angle[g] < 0.5) return true;
    return false;
  };
  if (std::all_of(region.begin(), region.end(), flat)) return false;
  ExactQuadric Q = fit_region(mesh, region, {T.E(e, 0), T.E(e, 1)}, opt);
  // A cyclide's 13 unknowns need two rings more; and where those reach across a rim (a coarse
  // half torus: chords turning up to 57 degrees, its rims 71-88), walls at theta + 15 degrees.
  // Only a cyclide: a quadric through these smaller or further regions was not one through
  // the first (Thingi10K 375236: 12 faces on a quadric, 3 false chords, 1.4% -> 8.3% off the input;
  // an elliptic cylinder). But a round one within the narrower walls: a hole's wall at Gmsh's sizes,
  // chords of 51 degrees, rims of 90 (1.5 x 51 + 15 reaches over them into the plate).
  for (int attempt = off_every_cyclide(Q) ? 1 : 0; attempt < 2 && !Q.valid && opt.cyclides; ++attempt) {
    if (attempt == 0) rings += 2;
    else wall = std::max(face_angle[e] + 15.0, min_wall_deg);
    region = grow(nullptr, {}, rings);
    Q = fit_region(mesh, region, {T.E(e, 0), T.E(e, 1)}, opt);
    Q.valid = Q.valid && (Q.cyclide() || (attempt == 1 && round_primitive(Q)));
  }
  // Else e may lie in the closed fan of an end on a sphere: a coarse dome's chords, whose regions
  // reach over a tangent junction.
  if (!Q.valid) return fan_sphere(mesh, T, T.E(e, 0), opt).valid || fan_sphere(mesh, T, T.E(e, 1), opt).valid;
  const std::vector<char> agree = agreeing(mesh, Q, region, opt);
  if (!agree[0] || !agree[1]) return false;
  if (all_agree(agree)) return true;
  // Faces across the quadric (a cylinder's flat cap whose corners are all on its rim, so on the
  // cylinder too) leave; what is left round e must still determine an exact quadric.
  const std::vector<int> side = grow(&agree, region, rings);
  const ExactQuadric Q2 = fit_region(mesh, side, {T.E(e, 0), T.E(e, 1)}, opt);
  return Q2.valid && all_agree(agreeing(mesh, Q2, side, opt));
}

std::vector<char> exact_quadric_edges(const Mesh& mesh, const Topology& T, const std::vector<double>& face_angle,
                                      const std::vector<char>& candidate, const ExactQuadricOptions& opt) {
  std::vector<char> chord(T.num_edges(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, T.num_edges(), 256), [&](const tbb::blocked_range<int>& r) {
    for (int e = r.begin(); e < r.end(); ++e) chord[e] = candidate[e] && edge_on_exact_quadric(mesh, T, e, face_angle, opt);
  });
  return chord;
}

ExactQuadric wedge_plane(const Mesh& mesh, const Wedges& W, int w, const ExactQuadricOptions& opt) {
  const std::vector<int> faces(W.wedge_faces.begin() + W.wedge_start[w], W.wedge_faces.begin() + W.wedge_start[w + 1]);
  // Five corners apart (by a thousandth of the fan's size): a needle's nearly coincident ends
  // leave three, and any three lie on a plane (a marching-tetrahedra torus: P4 2.5e-6 -> 3.9e-4).
  std::vector<Eigen::Vector3d> corners;
  for (int f : faces)
    for (int j = 0; j < 3; ++j) corners.push_back(mesh.V.row(mesh.F(f, j)).transpose());
  double size = 0;
  for (const Eigen::Vector3d& x : corners) size = std::max(size, (x - corners[0]).norm());
  std::vector<Eigen::Vector3d> apart;
  for (const Eigen::Vector3d& x : corners)
    if (std::none_of(apart.begin(), apart.end(), [&](const Eigen::Vector3d& y) { return (x - y).norm() <= 1e-3 * size; }))
      apart.push_back(x);
  if (apart.size() < 5) return ExactQuadric();
  ExactQuadric Q = fit_region(mesh, faces, {}, opt, true);
  if (!Q.plane()) Q.valid = false;  // a fan of 12 or more: only its plane
  return Q;
}

ExactQuadric wedge_exact_quadric(const Mesh& mesh, const Topology& T, const Wedges& W, int w,
                                 const ExactQuadricOptions& opt, StencilScratch& scratch) {
  StencilOptions so;
  so.min_rings = 1;
  so.max_rings = opt.rings;
  so.target_points = opt.wedge_points;
  const Stencil S = grow_stencil(mesh, T, W, w, so, scratch);
  ExactQuadric Q;
  if (S.faces.empty()) return Q;
  // Where the stencil's corners on no exact surface include some on feature curves, its corners
  // off them may still lie on one (fit_region's off_features).
  auto fit = [&](const std::vector<int>& faces) {
    ExactQuadric A = fit_region(mesh, faces, {W.wedge_vertex[w]}, opt, true);
    if (A.valid) return A;
    ExactQuadric B = fit_region(mesh, faces, {W.wedge_vertex[w]}, opt, true, false, &W);
    return B.valid ? B : A;
  };
  Q = fit(S.faces);
  if (Q.valid && !all_agree(agreeing(mesh, Q, S.faces, opt))) Q.valid = false;
  if ((Q.valid || (opt.cyclides && !off_every_cyclide(Q))) && opt.confirm_points > opt.wedge_points) {
    so.max_rings = opt.rings + 2;
    so.target_points = opt.confirm_points;
    const Stencil L = grow_stencil(mesh, T, W, w, so, scratch);
    if (L.faces.size() > S.faces.size()) {
      ExactQuadric C = fit(L.faces);
      C.valid = C.valid && all_agree(agreeing(mesh, C, L.faces, opt));
      // A quadric is confirmed by the larger stencil's quadric (not by a cyclide through it:
      // king's revolved profile), a cyclide by its cyclide; one the small stencil did not
      // determine may be determined by the larger.
      if (Q.valid)
        Q.valid = (C.valid && C.cyclide() == Q.cyclide()) ||
                  (!Q.cyclide() && region_ends_clearly(mesh, T, Q, W.wedge_vertex[w], opt, scratch));
      else if (C.valid && C.cyclide()) Q = C;
    }
  }
  // A closed fan round a smooth vertex that no quadric holds with its neighbours (a coarse cap's
  // apex inside a shallow crease or a tangent junction): its own sphere. A one-sided fan's corners
  // may lie on two rims, which lie on a sphere even where the face between them is a cylinder.
  const int v = W.wedge_vertex[w];
  if (!Q.valid && !W.one_sided(w) && !W.is_cone(v)) {
    ExactQuadric F = fan_sphere(mesh, T, v, opt);
    if (F.valid) Q = std::move(F);
  }
  return Q;
}

}  // namespace hocurve
