#include "engine/curving/tangent_junctions.hpp"

#include <Eigen/Geometry>
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace hocurve {

CurvatureJump curvature_jump(const Mesh& mesh, const Topology& T, const std::vector<char>& wall, int e,
                             JumpScratch& scratch) {
  CurvatureJump J;
  if (T.edge_faces[e].size() != 2) return J;
  const int a = T.E(e, 0), b = T.E(e, 1);
  const Eigen::Vector3d pa = mesh.V.row(a), pb = mesh.V.row(b);
  const double h = (pb - pa).norm();
  auto unit_normal = [&](int f) {
    const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)), p2 = mesh.V.row(mesh.F(f, 2));
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    const double l = n.norm();
    return l > 0 ? Eigen::Vector3d(n / l) : Eigen::Vector3d::Zero();
  };
  Eigen::Vector3d n = unit_normal(T.edge_faces[e][0]) + unit_normal(T.edge_faces[e][1]);
  if (!(h > 0) || !(n.norm() > 1e-12)) return J;
  n.normalize();
  Eigen::Vector3d t = pb - pa;
  t = (t - t.dot(n) * n).normalized();
  const Eigen::Vector3d s = n.cross(t), o = 0.5 * (pa + pb);
  std::vector<int>& ring = scratch.vertices;
  edge_region_vertices(mesh, T, wall, e, 3, scratch.faces, scratch.seen, ring);
  const int k = static_cast<int>(ring.size());
  constexpr int m = 8;
  if (k < m + 6) return J;
  // Normal equations, fixed size: their Cholesky factor is the R of the weighted system's QR, so
  // L(j, j) is column j's part outside the span of the columns before it, and the forward solve
  // gives Q^T z (the drop of the residual by each column in turn).
  Eigen::Matrix<double, m, m> G = Eigen::Matrix<double, m, m>::Zero();
  Eigen::Matrix<double, m, 1> Az = Eigen::Matrix<double, m, 1>::Zero();
  double zz = 0;
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector3d d = (Eigen::Vector3d(mesh.V.row(ring[i])) - o) / h;
    const double x = d.dot(t), y = d.dot(s), w = std::exp(-(x * x + y * y) / 2.0);
    const double yp = std::max(y, 0.0), z = d.dot(n);
    Eigen::Matrix<double, m, 1> row;
    row << 1, x, y, x * x, x * y, y * y, yp * yp, x * yp * yp;
    G.selfadjointView<Eigen::Lower>().rankUpdate(row, w * w);
    Az += (w * w * z) * row;
    zz += w * w * z * z;
  }
  const Eigen::LLT<Eigen::Matrix<double, m, m>> llt(G.selfadjointView<Eigen::Lower>());
  if (llt.info() != Eigen::Success) return J;
  const Eigen::Matrix<double, m, m> L = llt.matrixL();
  // Determined: no column (the jump columns last) nearly a combination of the ones before it.
  for (int j = 0; j < m; ++j)
    if (!(L(j, j) > 1e-3 * std::sqrt(G(j, j)))) return J;
  const Eigen::Matrix<double, m, 1> qz = L.triangularView<Eigen::Lower>().solve(Az);
  const Eigen::Matrix<double, m, 1> c = L.transpose().triangularView<Eigen::Upper>().solve(qz);
  if (!c.allFinite()) return J;
  const double r1 = std::max(zz - qz.squaredNorm(), 0.0);
  const double r0 = r1 + qz[m - 2] * qz[m - 2] + qz[m - 1] * qz[m - 1];
  J.determined = true;
  J.jump = std::abs(2 * c[m - 2]);
  J.residual_ratio = r0 > 0 ? std::sqrt(r1 / r0) : 1.0;
  return J;
}

}  // namespace hocurve
