#include "engine/curving/place_nodes.hpp"

#include "engine/core/stopwatch.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>

namespace hocurve {

Eigen::Vector3d blend_point(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits,
                            int f, const Eigen::Vector3d& xi) {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) x += xi[j] * mesh.V.row(mesh.F(f, j)).transpose();
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j)
    if (xi[j] != 0.0) out += xi[j] * fits[W.corner_wedge(f, j)].project(x);
  return out;
}

Eigen::Vector3d edge_barycentric(const Mesh& mesh, const Topology& T, int e, int f, double t) {
  Eigen::Vector3d xi = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) {
    if (mesh.F(f, j) == T.E(e, 0)) xi[j] = 1 - t;
    if (mesh.F(f, j) == T.E(e, 1)) xi[j] = t;
  }
  return xi;
}

PlacementResult place_nodes(const Mesh& mesh, const Topology& T, const Wedges& W,
                            const std::vector<LocalFit>& fits, const Features* feat,
                            const CurveFitResult* curves, int p, NodeDistribution d,
                            const LongEdgeResult* long_edge) {
  const auto t0 = Clock::now();
  PlacementResult R;
  R.mesh = high_order_frame(mesh, T, p, d);
  HighOrderMesh& hm = R.mesh;
  const int ne = T.num_edges(), nf = mesh.num_faces();
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  if (p <= 1) return R;
  const Eigen::VectorXd line = line_reference_nodes(p, d);
  const Eigen::MatrixXd tri = triangle_reference_nodes(p, d);

  std::vector<char> on_curve(ne, 0);
  if (feat && curves)
    for (int e = 0; e < ne; ++e)
      on_curve[e] = !feat->edge_feature.empty() && feat->edge_feature[e] && curves->fits[2 * e].degree >= 0;
  tbb::parallel_for(tbb::blocked_range<int>(0, ne), [&](const tbb::blocked_range<int>& r) {
    for (int e = r.begin(); e < r.end(); ++e) {
      const int a = T.E(e, 0);
      const int f = T.edge_faces[e].empty() ? -1 : T.edge_faces[e][0];
      // An unreached long edge goes on the PN curve of its first face (a long face, as all its
      // faces are; computed once per edge: conforming).
      const bool pn = long_edge && long_edge->unreached[e];
      for (int k = 1; k < p; ++k) {
        const double t = line[k];
        Eigen::Vector3d q;
        if (on_curve[e] || f < 0) {
          q = curves ? curve_edge_point(mesh, T, *curves, e, t)
                     : Eigen::Vector3d((1 - t) * mesh.V.row(a) + t * mesh.V.row(T.E(e, 1)));
        } else {
          const Eigen::Vector3d xi = edge_barycentric(mesh, T, e, f, t);
          q = pn ? long_face_point(mesh, W, f, xi, long_edge->options) : blend_point(mesh, W, fits, f, xi);
        }
        hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1) = q.transpose();
      }
    }
  });
  if (npf > 0)
    tbb::parallel_for(tbb::blocked_range<int>(0, nf), [&](const tbb::blocked_range<int>& r) {
      for (int f = r.begin(); f < r.end(); ++f) {
        const bool pn = long_edge && long_edge->face[f];
        Eigen::Matrix3d P, N;
        if (pn) {
          for (int j = 0; j < 3; ++j) P.row(j) = mesh.V.row(mesh.F(f, j));
          N = same_size_normals(mesh, W, f, long_edge->options);
        }
        for (int k = 0; k < npf; ++k) {
          const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
          const Eigen::Vector3d xi(1 - u - v, u, v);
          hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k) =
              (pn ? pn_triangle_point(P, N, xi) : blend_point(mesh, W, fits, f, xi)).transpose();
        }
      }
    });
  for (int e = 0; e < ne; ++e) {
    R.curve_edges += on_curve[e];
    R.long_edges += long_edge && long_edge->unreached[e] && !on_curve[e];
  }
  R.seconds = seconds_since(t0);
  return R;
}

}  // namespace hocurve
