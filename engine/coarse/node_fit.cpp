#include "engine/coarse/node_fit.hpp"

#include "engine/coarse/dense_surface.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <array>
#include <cmath>
#include <limits>

namespace hocurve {

namespace {

template <class F>
void parallel(int n, F&& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) body(i);
  });
}

/// Row of node g (element_node_indices' global numbering) in hm's storage.
Eigen::MatrixXd::RowXpr node_row(HighOrderMesh& hm, long long g) {
  const long long nv = hm.V.rows(), nen = hm.edge_nodes.rows();
  if (g < nv) return hm.V.row(g);
  if (g < nv + nen) return hm.edge_nodes.row(g - nv);
  return hm.face_nodes.row(g - nv - nen);
}

/// One residual r = (x(uv) - y) . d of element f, with its basis values at uv.
struct Residual {
  double r = 0;
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  Eigen::RowVectorXd phi;
};

/// Closest point of element f (nodes X) to y by projected Gauss-Newton from uv (clamped to the
/// reference triangle); returns uv.
Eigen::Vector2d project_on_element(const Eigen::MatrixXd& X, int p, const Eigen::Vector3d& y, Eigen::Vector2d uv) {
  for (int it = 0; it < 6; ++it) {
    Eigen::MatrixXd q(1, 2);
    q << uv[0], uv[1];
    Eigen::MatrixXd Xu, Xv;
    evaluate_triangle_tangents(X, p, q, Xu, Xv);
    const Eigen::Vector3d x = evaluate_triangle(X, p, q).row(0).transpose();
    Eigen::Matrix<double, 3, 2> J;
    J.col(0) = Xu.row(0).transpose(), J.col(1) = Xv.row(0).transpose();
    const Eigen::Matrix2d A = J.transpose() * J;
    if (!(std::abs(A.determinant()) > 1e-300)) break;
    const Eigen::Vector2d step = A.ldlt().solve(J.transpose() * (y - x));
    uv += step;
    uv = uv.cwiseMax(0.0);
    if (uv.sum() > 1) uv /= uv.sum();
    if (step.norm() < 1e-10) break;
  }
  return uv;
}

}  // namespace

NodeFitResult fit_nodes_to_dense(HighOrderMesh& hm, const Mesh& fine, const TriangleGrid& grid, const CoarseMap& map,
                                 const std::vector<char>& fixed_node, const NodeFitOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  NodeFitResult R;
  const int p = hm.order, nf = hm.num_faces();
  if (p < 2 || hm.distribution != NodeDistribution::Equispaced || opt.iterations <= 0 || nf == 0) return R;
  const int nn = triangle_node_count(p);
  const int nv = static_cast<int>(hm.V.rows());
  const long long ntotal = nv + hm.edge_nodes.rows() + hm.face_nodes.rows();

  // Unknowns: one move per free node, along the curved surface's normal there.
  std::vector<int> unknown(ntotal, -1);
  std::vector<int> free_nodes;
  for (long long g = nv; g < ntotal; ++g)
    if (g >= static_cast<long long>(fixed_node.size()) || !fixed_node[g]) {
      unknown[g] = static_cast<int>(free_nodes.size());
      free_nodes.push_back(static_cast<int>(g));
    }
  const int nu = static_cast<int>(free_nodes.size());
  R.free_nodes = nu;
  if (nu == 0) return R;

  const Eigen::MatrixXi lat = triangle_lattice(p);
  Eigen::MatrixXd node_uv = lat.cast<double>() / p;
  // Per node: summed element normals at the node (edge nodes: both elements), and the bound of
  // its move (element size / order).
  Eigen::MatrixXd dir = Eigen::MatrixXd::Zero(ntotal, 3);
  Eigen::VectorXd limit = Eigen::VectorXd::Constant(ntotal, std::numeric_limits<double>::infinity());
  std::vector<std::array<int, 66>> idx(nf);
  for (int f = 0; f < nf; ++f) {
    element_node_indices(hm, f, idx[f].data());
    const Eigen::MatrixXd X = element_nodes(hm, f);
    Eigen::MatrixXd Xu, Xv;
    evaluate_triangle_tangents(X, p, node_uv, Xu, Xv);
    double h = 0;
    for (int j = 0; j < 3; ++j) h += (X.row(j) - X.row((j + 1) % 3)).norm() / 3;
    for (int k = 0; k < nn; ++k) {
      const Eigen::Vector3d n = Eigen::Vector3d(Xu.row(k)).cross(Eigen::Vector3d(Xv.row(k)));
      if (n.norm() > 0) dir.row(idx[f][k]) += n.normalized().transpose();
      limit[idx[f][k]] = std::min(limit[idx[f][k]], opt.max_move * h / p);
    }
  }
  for (long long g = 0; g < ntotal; ++g)
    if (dir.row(g).norm() > 0) dir.row(g).normalize();

  // Reference samples of every element, and the dense vertices of each coarse face.
  const int q = std::max(opt.sample_degree, p);
  Eigen::MatrixXd suv((q + 1) * (q + 2) / 2, 2);
  {
    int r = 0;
    for (int j = 0; j <= q; ++j)
      for (int i = 0; i + j <= q; ++i) suv.row(r++) << double(i) / q, double(j) / q;
  }
  const Eigen::MatrixXd sphi = triangle_basis(p, suv);
  const Eigen::MatrixXd& Vc = map.vertex_coarse_bary;
  const Mesh& fm = fine;
  Eigen::VectorXd moved = Eigen::VectorXd::Zero(ntotal);  // along dir, so far

  for (int it = 0; it <= opt.iterations; ++it) {
    // Residuals of every element, both ways.
    std::vector<std::vector<Residual>> res(nf);
    parallel(nf, [&](int f) {
      const Eigen::MatrixXd X = element_nodes(hm, f);
      const Eigen::MatrixXd S = sphi * X;
      auto& out = res[f];
      for (Eigen::Index k = 0; k < S.rows(); ++k) {
        const Eigen::Vector3d x = S.row(k).transpose();
        int face = -1;
        grid_distance(grid, x, &face);
        if (face < 0) continue;
        Eigen::Vector3d bc;
        const Eigen::Vector3d y = closest_point_on_triangle(x, fm.V.row(fm.F(face, 0)).transpose(),
                                                            fm.V.row(fm.F(face, 1)).transpose(),
                                                            fm.V.row(fm.F(face, 2)).transpose(), bc);
        Residual r;
        r.d = x - y;
        r.r = r.d.norm();
        if (r.r > 0) r.d /= r.r;
        else {
          const Eigen::Vector3d a = fm.V.row(fm.F(face, 0)).transpose();
          const Eigen::Vector3d b = fm.V.row(fm.F(face, 1)).transpose(), c = fm.V.row(fm.F(face, 2)).transpose();
          r.d = (b - a).cross(c - a).normalized();
        }
        r.phi = sphi.row(k);
        out.push_back(std::move(r));
      }
      auto [b, e] = map.fine_vertices_in(f);
      for (const int* v = b; v != e; ++v) {
        const Eigen::Vector3d y = fm.V.row(*v).transpose();
        const Eigen::Vector2d uv = project_on_element(X, p, y, Eigen::Vector2d(Vc(*v, 1), Vc(*v, 2)));
        Eigen::MatrixXd quv(1, 2);
        quv << uv[0], uv[1];
        Eigen::MatrixXd Xu, Xv;
        evaluate_triangle_tangents(X, p, quv, Xu, Xv);
        const Eigen::Vector3d n = Eigen::Vector3d(Xu.row(0)).cross(Eigen::Vector3d(Xv.row(0)));
        if (!(n.norm() > 0)) continue;
        Residual r;
        r.phi = triangle_basis(p, quv).row(0);
        r.d = n.normalized();
        const Eigen::Vector3d gap = (r.phi * X).transpose() - y;
        r.r = gap.dot(r.d);
        // Not a normal foot (the closest point left the element, clamped): the neighbour's.
        if ((gap - r.r * r.d).norm() > 0.25 * std::abs(r.r) + 1e-12 * (X.row(1) - X.row(0)).norm()) continue;
        out.push_back(std::move(r));
      }
    });
    double sum2 = 0;
    long long count = 0;
    for (const auto& rs : res)
      for (const Residual& r : rs) sum2 += r.r * r.r, ++count;
    const double rms = count ? std::sqrt(sum2 / count) : 0;
    if (it == 0) R.rms_before = rms;
    R.rms_after = rms;
    if (it == opt.iterations) break;

    // Normal equations of the moves s: residual r + sum_i phi_i (dir_i . d) s_i.
    std::vector<std::vector<Eigen::Triplet<double>>> trip(nf);
    std::vector<std::vector<std::pair<int, double>>> rhs(nf);
    parallel(nf, [&](int f) {
      for (const Residual& r : res[f]) {
        int cols[66];
        double a[66];
        int m = 0;
        for (int k = 0; k < nn; ++k) {
          const int u = unknown[idx[f][k]];
          if (u < 0 || r.phi[k] == 0) continue;
          cols[m] = u, a[m] = r.phi[k] * dir.row(idx[f][k]).dot(r.d.transpose()), ++m;
        }
        for (int i = 0; i < m; ++i) {
          rhs[f].emplace_back(cols[i], -a[i] * r.r);
          for (int j = 0; j < m; ++j) trip[f].emplace_back(cols[i], cols[j], a[i] * a[j]);
        }
      }
    });
    std::vector<Eigen::Triplet<double>> all;
    Eigen::VectorXd b = Eigen::VectorXd::Zero(nu);
    for (int f = 0; f < nf; ++f) {
      all.insert(all.end(), trip[f].begin(), trip[f].end());
      for (auto [u, v] : rhs[f]) b[u] += v;
    }
    Eigen::SparseMatrix<double> N(nu, nu);
    N.setFromTriplets(all.begin(), all.end());
    double mean_diag = 0;
    for (int u = 0; u < nu; ++u) mean_diag += N.coeff(u, u);
    mean_diag = mean_diag > 0 ? mean_diag / nu : 1;
    for (int u = 0; u < nu; ++u) N.coeffRef(u, u) += opt.damping * mean_diag;
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(N);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd s = solver.solve(b);
    if (solver.info() != Eigen::Success || !s.allFinite()) break;
    for (int u = 0; u < nu; ++u) {
      const int g = free_nodes[u];
      const double total = std::clamp(moved[g] + s[u], -limit[g], limit[g]);
      const double step = total - moved[g];
      moved[g] = total;
      node_row(hm, g) += step * dir.row(g);
    }
  }
  R.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return R;
}

}  // namespace hocurve
