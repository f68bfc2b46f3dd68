// Validity of curved triangles by Bernstein bounds of the signed Jacobian determinant
// (Johnen, Remacle, Geuzaine 2013), with subdivision for undecided elements, and a repair
// that shrinks the high-order displacement of invalid elements.
#include "engine/highorder/validity.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/needles.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/LU>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace hocurve {

namespace {

// Bernstein coefficients decide "valid" once they clear the threshold by this fraction of
// their magnitude (rounding in the products must not certify a zero).
constexpr double kCertify = 1e-10;

void check_options(const ValidityOptions& opt) {
  if (opt.max_subdivisions < 0 || opt.max_subdivisions > 12)
    throw UsageError("validity: max_subdivisions " + std::to_string(opt.max_subdivisions) + " out of range 0..12");
  if (!(opt.shrink > 0 && opt.shrink < 1))
    throw UsageError("validity: shrink " + std::to_string(opt.shrink) + " must be in (0, 1)");
  if (opt.max_shrink_steps < 0)
    throw UsageError("validity: max_shrink_steps " + std::to_string(opt.max_shrink_steps) + " must be >= 0");
  if (!(opt.min_scaled_jacobian < 1) || !(opt.quality_floor < 1))
    throw UsageError("validity: min_scaled_jacobian " + std::to_string(opt.min_scaled_jacobian) + " and quality_floor " +
                     std::to_string(opt.quality_floor) + " must be < 1 (straight elements have 1)");
}

// Scratch buffers of one thread; sized for one basis.
struct Workspace {
  std::vector<double> xyz;              // #nodes x 3, row-major
  std::vector<double> xy;               // #nodes x 2, row-major (local frame, scaled)
  std::vector<double> P;                // control points, #nodes x 2 row-major
  std::vector<double> Du, Dv;           // derivative nets, #count(p-1) x 2 row-major
  std::vector<double> b;                // J / J_straight coefficients
  std::vector<std::vector<double>> lv;  // per depth: 4 children + samples
  explicit Workspace(const JacobianBasis& B, int max_depth) {
    const int n = B.num_nodes, m = bernstein_count(std::max(B.p - 1, 0)), c = B.num_coefficients;
    xyz.resize(3 * n);
    xy.resize(2 * n);
    P.resize(2 * n);
    Du.resize(2 * m);
    Dv.resize(2 * m);
    b.resize(c);
    lv.assign(max_depth + 1, std::vector<double>(5 * c));
  }
};

// Maps xyz (row-major) to 2D coordinates in the straight triangle's frame, scaled by
// 1/sqrt(J_straight) so that the Jacobian computed from them is J / J_straight.
// Returns false when the straight triangle is degenerate (or not finite).
bool local_frame(const double* X, int n, double* xy) {
  const double* a = X;
  const double* b = X + 3;
  const double* c = X + 6;
  const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double e3[3] = {c[0] - b[0], c[1] - b[1], c[2] - b[2]};
  const double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double js = std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  auto sq = [](const double* v) { return v[0] * v[0] + v[1] * v[1] + v[2] * v[2]; };
  const double lmax = std::max({sq(e1), sq(e2), sq(e3)});
  if (!(js > kZeroArea * lmax) || !std::isfinite(js)) return false;
  const double l1 = std::sqrt(sq(e1));
  const double nn[3] = {cr[0] / js, cr[1] / js, cr[2] / js};
  const double t1[3] = {e1[0] / l1, e1[1] / l1, e1[2] / l1};
  // t2 = n x t1, so (t1, t2, n) is right-handed and n . (a x b) = a_1 b_2 - a_2 b_1.
  const double t2[3] = {nn[1] * t1[2] - nn[2] * t1[1], nn[2] * t1[0] - nn[0] * t1[2], nn[0] * t1[1] - nn[1] * t1[0]};
  const double s = 1 / std::sqrt(js);
  for (int k = 0; k < n; ++k) {
    const double d[3] = {X[3 * k] - a[0], X[3 * k + 1] - a[1], X[3 * k + 2] - a[2]};
    xy[2 * k] = s * (d[0] * t1[0] + d[1] * t1[1] + d[2] * t1[2]);
    xy[2 * k + 1] = s * (d[0] * t2[0] + d[1] * t2[1] + d[2] * t2[2]);
  }
  return true;
}

// Route B on the local 2D coordinates: control points, derivative nets, exact product.
void bezier_from_local(const JacobianBasis& B, Workspace& ws) {
  const int n = B.num_nodes, p = B.p;
  const double* M = B.to_bernstein.data();  // column-major n x n
  std::fill(ws.P.begin(), ws.P.end(), 0.0);
  for (int k = 0; k < n; ++k) {
    const double x = ws.xy[2 * k], y = ws.xy[2 * k + 1];
    const double* col = M + static_cast<size_t>(k) * n;
    for (int i = 0; i < n; ++i) {
      ws.P[2 * i] += col[i] * x;
      ws.P[2 * i + 1] += col[i] * y;
    }
  }
  // Derivative nets (degree p-1).
  for (int b2 = 0; b2 < p; ++b2)
    for (int b1 = 0; b1 + b2 < p; ++b1) {
      const int i = bernstein_index(p - 1, b1, b2);
      const int i0 = bernstein_index(p, b1, b2), i1 = bernstein_index(p, b1 + 1, b2), i2 = bernstein_index(p, b1, b2 + 1);
      for (int c = 0; c < 2; ++c) {
        ws.Du[2 * i + c] = p * (ws.P[2 * i1 + c] - ws.P[2 * i0 + c]);
        ws.Dv[2 * i + c] = p * (ws.P[2 * i2 + c] - ws.P[2 * i0 + c]);
      }
    }
  std::fill(ws.b.begin(), ws.b.end(), 0.0);
  for (const auto& t : B.product.terms)
    ws.b[t.ig] += t.coef * (ws.Du[2 * t.ia] * ws.Dv[2 * t.ib + 1] - ws.Dv[2 * t.ia] * ws.Du[2 * t.ib + 1]);
}

void matvec(const Eigen::MatrixXd& A, const double* x, double* y) {
  const int r = static_cast<int>(A.rows()), c = static_cast<int>(A.cols());
  const double* a = A.data();
  std::fill(y, y + r, 0.0);
  for (int j = 0; j < c; ++j) {
    const double xj = x[j];
    const double* col = a + static_cast<size_t>(j) * r;
    for (int i = 0; i < r; ++i) y[i] += col[i] * xj;
  }
}

struct Range {
  double mn, mx, absmax;
  bool finite;
};

Range range_of(const double* b, int n) {
  Range r{b[0], b[0], 0, true};
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(b[i])) r.finite = false;
    r.mn = std::min(r.mn, b[i]);
    r.mx = std::max(r.mx, b[i]);
    r.absmax = std::max(r.absmax, std::abs(b[i]));
  }
  return r;
}

// Decision rule of Johnen et al. 2013 (docs/algorithm.md, section 7) on coefficients b (scaled). On VALID, lo/hi are folded with
// the leaves' bounds. `deepest` records the deepest level visited.
bool classify(const JacobianBasis& B, const double* b, int depth, int cap, double thr, Workspace& ws, double& lo,
              double& hi, int& deepest) {
  const int n = B.num_coefficients;
  deepest = std::max(deepest, depth);
  const Range r = range_of(b, n);
  if (!r.finite) return false;
  if (r.mn - thr > kCertify * r.absmax) {
    lo = std::min(lo, r.mn);
    hi = std::max(hi, r.mx);
    return true;
  }
  double* buf = ws.lv[depth].data();
  double* samples = buf + 4 * n;
  matvec(B.lattice_values, b, samples);
  for (int i = 0; i < n; ++i)
    if (samples[i] <= thr) return false;  // a true value of J: certainly invalid
  if (depth >= cap) return false;         // undecided counts as invalid
  double mins[4];
  int order[4] = {0, 1, 2, 3};
  for (int c = 0; c < 4; ++c) {
    matvec(B.children[c], b, buf + c * n);
    mins[c] = *std::min_element(buf + c * n, buf + (c + 1) * n);
  }
  // Smallest minimum first: an invalid child ends the search early.
  std::sort(order, order + 4, [&](int x, int y) { return mins[x] < mins[y] || (mins[x] == mins[y] && x < y); });
  for (int c : order)
    if (!classify(B, buf + c * n, depth + 1, cap, thr, ws, lo, hi, deepest)) return false;
  return true;
}

// Checks the element whose nodes are in ws.xyz.
ElementValidity check_loaded(const JacobianBasis& B, Workspace& ws, const ValidityOptions& opt) {
  ElementValidity ev;
  if (!local_frame(ws.xyz.data(), B.num_nodes, ws.xy.data())) {
    ev.degenerate = true;
    return ev;
  }
  bezier_from_local(B, ws);
  const Range r = range_of(ws.b.data(), B.num_coefficients);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  int deepest = 0;
  ev.valid = classify(B, ws.b.data(), 0, opt.max_subdivisions, opt.min_scaled_jacobian, ws, lo, hi, deepest);
  ev.subdivisions = deepest;
  if (ev.valid) {
    ev.min_scaled_jacobian = lo;
    ev.max_scaled_jacobian = hi;
  } else {
    ev.min_scaled_jacobian = r.finite ? r.mn : -std::numeric_limits<double>::infinity();
    ev.max_scaled_jacobian = r.finite ? r.mx : std::numeric_limits<double>::infinity();
  }
  return ev;
}

void load_matrix(const Eigen::MatrixXd& nodes, const JacobianBasis& B, Workspace& ws, const char* where) {
  if (nodes.rows() != B.num_nodes || nodes.cols() != 3)
    throw UsageError(std::string(where) + ": nodes must be " + std::to_string(B.num_nodes) + " x 3 for order " +
                     std::to_string(B.p) + ", got " + std::to_string(nodes.rows()) + " x " +
                     std::to_string(nodes.cols()));
  for (int k = 0; k < B.num_nodes; ++k)
    for (int c = 0; c < 3; ++c) ws.xyz[3 * k + c] = nodes(k, c);
}

// Gathers face f's nodes (Gmsh order) into ws.xyz.
void load_face(const HighOrderMesh& hm, int f, Workspace& ws) {
  int idx[66];
  element_node_indices(hm, f, idx);
  const int nv = static_cast<int>(hm.V.rows());
  const int ned = static_cast<int>(hm.edge_nodes.rows());
  const int n = triangle_node_count(hm.order);
  for (int k = 0; k < n; ++k) {
    const int g = idx[k];
    const Eigen::MatrixXd& M = g < nv ? hm.V : (g < nv + ned ? hm.edge_nodes : hm.face_nodes);
    const int r = g < nv ? g : (g < nv + ned ? g - nv : g - nv - ned);
    for (int c = 0; c < 3; ++c) ws.xyz[3 * k + c] = M(r, c);
  }
}

void check_mesh_shape(const HighOrderMesh& hm, const char* where) {
  const int p = hm.order;
  if (p < 1 || p > 10) throw UsageError(std::string(where) + ": order " + std::to_string(p) + " out of range 1..10");
  const Eigen::Index nf = hm.F.rows(), ne = hm.E.rows();
  if (hm.FE.rows() != nf || hm.edge_nodes.rows() != ne * (p - 1) || hm.face_nodes.rows() != nf * hm.nodes_per_face())
    throw InputError(where, "high-order mesh arrays do not match (" + std::to_string(nf) + " faces, " +
                                std::to_string(ne) + " edges, " + std::to_string(hm.edge_nodes.rows()) +
                                " edge nodes, " + std::to_string(hm.face_nodes.rows()) + " face nodes, order " +
                                std::to_string(p) + ")");
  if (nf > 0 && (hm.F.cols() != 3 || hm.FE.cols() != 3 || hm.E.cols() != 2))
    throw InputError(where, "F and FE must have 3 columns and E 2");
  const Eigen::Index nv = hm.V.rows();
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      if (hm.F(f, j) < 0 || hm.F(f, j) >= nv)
        throw InputError(where, "face " + std::to_string(f) + ": vertex index " + std::to_string(hm.F(f, j)) +
                                    " out of range 0.." + std::to_string(nv - 1));
      if (hm.FE(f, j) < 0 || hm.FE(f, j) >= ne)
        throw InputError(where, "face " + std::to_string(f) + ": edge index " + std::to_string(hm.FE(f, j)) +
                                    " out of range 0.." + std::to_string(ne - 1));
    }
}

// Checks the faces listed in `faces` into out[face] (parallel, deterministic).
void check_faces(const HighOrderMesh& hm, const JacobianBasis& B, const ValidityOptions& opt,
                 const std::vector<int>& faces, std::vector<ElementValidity>& out) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, faces.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
    Workspace ws(B, opt.max_subdivisions);
    for (size_t i = r.begin(); i != r.end(); ++i) {
      load_face(hm, faces[i], ws);
      out[faces[i]] = check_loaded(B, ws, opt);
    }
  });
}

void fill_report(const std::vector<ElementValidity>& ev, ValidityReport& rep) {
  rep.checked = static_cast<long long>(ev.size());
  rep.invalid_after = 0;
  rep.degenerate_input = 0;
  rep.invalid_faces.clear();
  double mn = std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < ev.size(); ++f) {
    if (ev[f].degenerate) ++rep.degenerate_input;
    else mn = std::min(mn, ev[f].min_scaled_jacobian);
    if (!ev[f].valid) {
      ++rep.invalid_after;
      rep.invalid_faces.push_back(static_cast<int>(f));
    }
  }
  rep.min_scaled_jacobian = std::isinf(mn) ? 0.0 : mn;
}

}  // namespace

JacobianBasis::JacobianBasis(int p_) : p(p_) {
  if (p < 1 || p > 10) throw UsageError("JacobianBasis: order " + std::to_string(p) + " out of range 1..10");
  d = 2 * (p - 1);
  num_nodes = triangle_node_count(p);
  num_coefficients = bernstein_count(d);
  to_bernstein = lagrange_to_bernstein(p);
  product = make_bernstein_product(p - 1, p - 1);
  const Eigen::MatrixXd lat = bernstein_lattice(d);
  lattice_values = bernstein_matrix(d, lat);
  lattice_to_bernstein = lattice_values.fullPivLu().inverse();
  triangle_basis_gradients(p, lat, grad_u, grad_v);
  for (int c = 0; c < 4; ++c) children[c] = bernstein_subdivision_matrix(d, c);
}

Eigen::VectorXd jacobian_bezier(const JacobianBasis& basis, const Eigen::MatrixXd& nodes) {
  Workspace ws(basis, 0);
  load_matrix(nodes, basis, ws, "jacobian_bezier");
  if (!local_frame(ws.xyz.data(), basis.num_nodes, ws.xy.data())) return {};
  bezier_from_local(basis, ws);
  return Eigen::Map<const Eigen::VectorXd>(ws.b.data(), basis.num_coefficients);
}

Eigen::VectorXd jacobian_bezier_sampled(const JacobianBasis& basis, const Eigen::MatrixXd& nodes) {
  Workspace ws(basis, 0);
  load_matrix(nodes, basis, ws, "jacobian_bezier_sampled");
  if (!local_frame(ws.xyz.data(), basis.num_nodes, ws.xy.data())) return {};
  const Eigen::MatrixXd xy = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>>(
      ws.xy.data(), basis.num_nodes, 2);
  const Eigen::MatrixXd Xu = basis.grad_u * xy, Xv = basis.grad_v * xy;
  const Eigen::VectorXd j = Xu.col(0).cwiseProduct(Xv.col(1)) - Xv.col(0).cwiseProduct(Xu.col(1));
  return basis.lattice_to_bernstein * j;
}

double bezier_lower_bound(const JacobianBasis& basis, const Eigen::VectorXd& b, int depth) {
  if (b.size() != basis.num_coefficients)
    throw UsageError("bezier_lower_bound: expected " + std::to_string(basis.num_coefficients) + " coefficients");
  if (depth <= 0) return b.minCoeff();
  double lo = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 4; ++c) lo = std::min(lo, bezier_lower_bound(basis, basis.children[c] * b, depth - 1));
  return lo;
}

ElementValidity check_element(const Eigen::MatrixXd& nodes, int p, const ValidityOptions& opt) {
  const JacobianBasis basis(p);
  return check_element(basis, nodes, opt);
}

ElementValidity check_element(const JacobianBasis& basis, const Eigen::MatrixXd& nodes, const ValidityOptions& opt) {
  check_options(opt);
  Workspace ws(basis, opt.max_subdivisions);
  load_matrix(nodes, basis, ws, "check_element");
  return check_loaded(basis, ws, opt);
}

std::vector<ElementValidity> check_elements(const HighOrderMesh& hm, const ValidityOptions& opt) {
  check_options(opt);
  check_mesh_shape(hm, "check_elements");
  const JacobianBasis basis(hm.order);
  std::vector<int> faces(hm.F.rows());
  for (size_t f = 0; f < faces.size(); ++f) faces[f] = static_cast<int>(f);
  std::vector<ElementValidity> out(faces.size());
  check_faces(hm, basis, opt, faces, out);
  return out;
}

ValidityReport check_validity(const HighOrderMesh& hm, const ValidityOptions& opt) {
  const std::vector<ElementValidity> ev = check_elements(hm, opt);
  ValidityReport rep;
  fill_report(ev, rep);
  rep.invalid_before = rep.invalid_after;
  if (opt.quality_floor > opt.min_scaled_jacobian) {
    // Bounds are only refined until they clear the threshold: against the floor they are tighter.
    ValidityOptions q = opt;
    q.min_scaled_jacobian = opt.quality_floor;
    std::vector<ElementValidity> eq = check_elements(hm, q);
    ValidityReport rq;
    fill_report(eq, rq);
    rep.min_scaled_jacobian = std::max(rep.min_scaled_jacobian, rq.min_scaled_jacobian);
    rep.below_floor_before = rq.invalid_after - rq.degenerate_input;
  }
  return rep;
}

namespace {
/// Largest s in [0, 1] (to 2^-12) for which face f, its high-order displacement from its straight
/// shape (ref: reference nodes, Gmsh order) scaled by s, passes the check at opt. Bisection from
/// s = 0, the straight triangle (valid unless degenerate). Why not a fixed shrink step: an element
/// just below the threshold needs 1% of its displacement taken off, and a 20% step took off 20% of
/// the curvature of every edge it shares (T20 d/20 P4, a fillet's border circle: 4.8e-5 -> 2.4e-2).
double largest_valid_scale(const HighOrderMesh& hm, int f, const Eigen::MatrixXd& ref, const JacobianBasis& B,
                           const ValidityOptions& opt, Workspace& ws) {
  load_face(hm, f, ws);
  const int n = B.num_nodes;
  std::vector<double> straight(3 * n), curved(ws.xyz);
  for (int k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c)
      straight[3 * k + c] = curved[c] + ref(k, 0) * (curved[3 + c] - curved[c]) + ref(k, 1) * (curved[6 + c] - curved[c]);
  double lo = 0, hi = 1;
  for (int it = 0; it < 12; ++it) {
    const double s = 0.5 * (lo + hi);
    for (int i = 9; i < 3 * n; ++i) ws.xyz[i] = straight[i] + s * (curved[i] - straight[i]);
    (check_loaded(B, ws, opt).valid ? lo : hi) = s;
  }
  return lo;
}

/// Face f fails the check at opt only at its corners, and there barely: the Jacobian sampled on the
/// degree-d lattice is above the threshold everywhere else and above -max_corner_fold at the
/// corners. There two of its sides leave a corner along one tangent, as where two feature curves
/// meet tangentially (T20's nut chamfer vanishing where its top circle touches a hex flat:
/// J / J_straight -0.003 at that corner and above 0.04 at every other sample). A side that bulges
/// into the element folds it at both its ends too, but further (-0.2 for a P2 side's node 0.3 of
/// the height in).
bool fails_at_corners_only(const HighOrderMesh& hm, int f, const JacobianBasis& B, const ValidityOptions& opt,
                           Workspace& ws) {
  constexpr double max_corner_fold = 0.05;
  load_face(hm, f, ws);
  if (!local_frame(ws.xyz.data(), B.num_nodes, ws.xy.data())) return false;
  bezier_from_local(B, ws);
  const int n = B.num_coefficients, d = 2 * (B.p - 1);
  std::vector<double> samples(n);
  matvec(B.lattice_values, ws.b.data(), samples.data());
  const int corners[3] = {0, d, bernstein_index(d, 0, d)};
  bool corner = false;
  for (int i = 0; i < n; ++i) {
    const bool at_corner = i == corners[0] || i == corners[1] || i == corners[2];
    if (!(samples[i] > opt.min_scaled_jacobian)) {
      if (!at_corner || !(samples[i] > -max_corner_fold)) return false;
      corner = true;
    }
  }
  return corner;
}

/// Every face of hm checked at opt (parallel, deterministic).
std::vector<ElementValidity> check_all(const HighOrderMesh& hm, const JacobianBasis& basis,
                                       const ValidityOptions& opt) {
  std::vector<int> all(hm.F.rows());
  for (size_t f = 0; f < all.size(); ++f) all[f] = static_cast<int>(f);
  std::vector<ElementValidity> ev(all.size());
  check_faces(hm, basis, opt, all, ev);
  return ev;
}

/// One repair pass at opt.min_scaled_jacobian (what repair_validity documents, without the floor).
/// ev holds every face's check at that threshold and is kept current; the faces whose nodes moved
/// are appended to `moved`. (A check is a function of the element's nodes alone, so updating the
/// moved faces equals checking the whole mesh again, which cost 0.1 s a pass on 200k faces.)
/// corner_folds: faces that fail at their corners only (fails_at_corners_only) are bisected where
/// opt.bisect is off.
ValidityReport repair_pass(HighOrderMesh& hm, const JacobianBasis& basis, const ValidityOptions& opt,
                           std::vector<ElementValidity>& ev, std::vector<int>& moved, bool corner_folds = false) {
  const int p = hm.order, npe = p - 1, npf = hm.nodes_per_face();
  const int nf = static_cast<int>(hm.F.rows()), ne = static_cast<int>(hm.E.rows());
  ValidityReport rep;
  fill_report(ev, rep);
  rep.invalid_before = rep.invalid_after;
  if (rep.invalid_after == 0 || p == 1) return rep;

  // Straight positions, computed exactly as make_straight_high_order does for
  // hm.distribution, so that alpha = 0 reproduces the straight mesh bit for bit.
  const Eigen::VectorXd t = line_reference_nodes(p, hm.distribution);
  Eigen::MatrixXd edge_straight(hm.edge_nodes.rows(), 3), face_straight(hm.face_nodes.rows(), 3);
  for (int e = 0; e < ne; ++e) {
    const Eigen::RowVector3d a = hm.V.row(hm.E(e, 0)), b = hm.V.row(hm.E(e, 1));
    for (int k = 1; k < p; ++k) edge_straight.row(static_cast<Eigen::Index>(e) * npe + k - 1) = a + t[k] * (b - a);
  }
  if (npf > 0) {
    const Eigen::MatrixXd ref = triangle_reference_nodes(p, hm.distribution);
    for (int f = 0; f < nf; ++f) {
      const Eigen::RowVector3d a = hm.V.row(hm.F(f, 0)), b = hm.V.row(hm.F(f, 1)), c = hm.V.row(hm.F(f, 2));
      for (int k = 0; k < npf; ++k) {
        const double u = ref(3 * p + k, 0), v = ref(3 * p + k, 1);
        face_straight.row(static_cast<Eigen::Index>(f) * npf + k) = a + u * (b - a) + v * (c - a);
      }
    }
  }
  const Eigen::MatrixXd edge_curved = hm.edge_nodes, face_curved = hm.face_nodes;

  // Faces of each edge (for re-checking neighbours).
  std::vector<std::vector<int>> edge_faces(ne);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) edge_faces[hm.FE(f, j)].push_back(f);

  std::vector<double> alpha_e(ne, 1.0), alpha_f(nf, 1.0);
  std::vector<int> steps(nf, 0);
  std::vector<char> edge_mark(ne, 0), face_mark(nf, 0);
  // alpha = 0 is exactly straight, even when the curved node is not finite.
  auto blend = [](const Eigen::RowVector3d& straight, const Eigen::RowVector3d& curved, double alpha) {
    return alpha == 0 ? straight : Eigen::RowVector3d(straight + alpha * (curved - straight));
  };
  auto straight_face = [&](int f) {
    if (alpha_f[f] != 0) return false;
    for (int j = 0; j < 3; ++j)
      if (alpha_e[hm.FE(f, j)] != 0) return false;
    return true;
  };

  std::vector<int> bad;
  for (int f : rep.invalid_faces)
    if (!ev[f].degenerate) bad.push_back(f);
  const Eigen::MatrixXd ref = triangle_reference_nodes(p, hm.distribution);
  std::vector<double> scale(nf, 1.0), edge_scale(ne, 1.0);
  // Rounds: every invalid face scales its own and its edges' displacement by the largest factor
  // that makes it valid alone (opt.bisect; from the second round on at most opt.shrink; else by
  // opt.shrink; an edge shared by two invalid faces takes the smaller factor); after
  // max_shrink_steps rounds a face goes fully straight. Set-based, so the result does not depend
  // on the processing order.
  // A face's way (bisected or fixed steps) is decided when it first fails.
  std::vector<char> bisect(nf, opt.bisect);
  while (!bad.empty()) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bad.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
      Workspace ws(basis, opt.max_subdivisions);
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const int f = bad[i];
        if (corner_folds && !opt.bisect && steps[f] == 0) bisect[f] = fails_at_corners_only(hm, f, basis, opt, ws);
        if (bisect[f]) scale[f] = largest_valid_scale(hm, f, ref, basis, opt, ws);
      }
    });
    std::vector<int> touched_edges;
    for (int f : bad) {
      ++steps[f];
      const bool flatten = steps[f] > opt.max_shrink_steps;
      const double s = !bisect[f] ? opt.shrink : steps[f] == 1 ? scale[f] : std::min(scale[f], opt.shrink);
      alpha_f[f] = flatten ? 0.0 : alpha_f[f] * s;
      for (int j = 0; j < 3; ++j) {
        const int e = hm.FE(f, j);
        if (!edge_mark[e]) touched_edges.push_back(e);
        edge_mark[e] = std::max<char>(edge_mark[e], flatten ? 2 : 1);
        edge_scale[e] = std::min(edge_scale[e], s);
      }
      for (int k = 0; k < npf; ++k) {
        const Eigen::Index r = static_cast<Eigen::Index>(f) * npf + k;
        hm.face_nodes.row(r) = blend(face_straight.row(r), face_curved.row(r), alpha_f[f]);
      }
    }
    std::sort(touched_edges.begin(), touched_edges.end());
    std::vector<int> recheck;
    for (int e : touched_edges) {
      alpha_e[e] = edge_mark[e] == 2 ? 0.0 : alpha_e[e] * edge_scale[e];
      edge_mark[e] = 0;
      edge_scale[e] = 1.0;
      for (int k = 0; k < npe; ++k) {
        const Eigen::Index r = static_cast<Eigen::Index>(e) * npe + k;
        hm.edge_nodes.row(r) = blend(edge_straight.row(r), edge_curved.row(r), alpha_e[e]);
      }
      for (int f : edge_faces[e])
        if (!face_mark[f]) {
          face_mark[f] = 1;
          recheck.push_back(f);
        }
    }
    std::sort(recheck.begin(), recheck.end());
    for (int f : recheck) face_mark[f] = 0;
    check_faces(hm, basis, opt, recheck, ev);
    moved.insert(moved.end(), recheck.begin(), recheck.end());
    bad.clear();
    for (int f : recheck)
      if (!ev[f].valid && !ev[f].degenerate && !straight_face(f)) bad.push_back(f);
  }

  fill_report(ev, rep);
  rep.repaired = 0;
  for (int f = 0; f < nf; ++f) {
    bool moved = alpha_f[f] < 1 && npf > 0;
    for (int j = 0; j < 3; ++j) moved = moved || alpha_e[hm.FE(f, j)] < 1;
    if (moved) ++rep.repaired;
  }
  return rep;
}
}  // namespace

ValidityReport repair_validity(HighOrderMesh& hm, const ValidityOptions& opt,
                               std::vector<ElementValidity> floor_checks) {
  check_options(opt);
  check_mesh_shape(hm, "repair_validity");
  const JacobianBasis basis(hm.order);
  ValidityOptions fixed = opt;  // invalid elements: fixed steps (see ValidityOptions::bisect)
  fixed.bisect = false;
  // Each element is checked in full once per threshold; the passes below update what they move.
  std::vector<ElementValidity> ev = check_all(hm, basis, opt);
  ValidityReport first;
  fill_report(ev, first);
  long long needles = 0;
  if (opt.needle_short_edge > 0 && hm.order > 1) {
    const std::vector<int> bad = needle_faces(hm, first.invalid_faces, opt.needle_short_edge);
    if (!bad.empty()) needles = align_needles(hm, bad, opt.needle_short_edge);
    if (needles > 0) ev = check_all(hm, basis, opt);
  }
  std::vector<int> moved;
  // Invalid faces that fail at their corners only are bisected all the same where bisection is on:
  // their nodes are not suspect, and a fixed step took 20% off the curvature of every side they
  // share (T20 at d/20, P4 7.5e-4 -> 7.2e-3 round the nut chamfer's vanishing ends). Not where it is
  // off (coarse lifting, LiftOptions::validity: bunny_closed's re-decimated deviation 0.57% -> 0.82%).
  ValidityReport rep = repair_pass(hm, basis, fixed, ev, moved, opt.bisect);
  rep.needles_aligned = needles;
  rep.invalid_before = first.invalid_after;
  if (!(opt.quality_floor > opt.min_scaled_jacobian) || hm.order == 1) return rep;
  // Then the valid elements that come near folding (min J / J_straight below the floor) go the
  // same way toward straight until they clear it; the report keeps the validity threshold.
  ValidityOptions q = opt;
  q.min_scaled_jacobian = opt.quality_floor;
  std::vector<ElementValidity> eq;
  if (needles == 0 && floor_checks.size() == static_cast<size_t>(hm.F.rows())) {
    eq = std::move(floor_checks);  // current but for the faces the first pass moved
    std::sort(moved.begin(), moved.end());
    moved.erase(std::unique(moved.begin(), moved.end()), moved.end());
    check_faces(hm, basis, q, moved, eq);
  } else {
    eq = check_all(hm, basis, q);
  }
  moved.clear();
  const ValidityReport rq = repair_pass(hm, basis, q, eq, moved);
  std::sort(moved.begin(), moved.end());
  moved.erase(std::unique(moved.begin(), moved.end()), moved.end());
  check_faces(hm, basis, opt, moved, ev);
  ValidityReport out;
  fill_report(ev, out);
  // As check_validity: bounds are only refined until they clear the threshold, so against the
  // floor they are tighter.
  out.min_scaled_jacobian = std::max(out.min_scaled_jacobian, rq.min_scaled_jacobian);
  out.invalid_before = rep.invalid_before;
  out.repaired = rep.repaired;
  out.below_floor_before = rq.invalid_before - rq.degenerate_input;
  out.quality_repaired = rq.repaired;
  out.needles_aligned = needles;
  return out;
}

}  // namespace hocurve
