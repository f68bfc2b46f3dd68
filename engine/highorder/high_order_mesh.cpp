// Straight high-order meshes and the mapping from shared edge / face storage to Gmsh's
// per-element node lists.
#include "engine/highorder/high_order_mesh.hpp"

#include "engine/core/error.hpp"

#include <initializer_list>
#include <string>

namespace hocurve {

HighOrderMesh high_order_frame(const Mesh& mesh, const Topology& T, int p, NodeDistribution d) {
  HighOrderMesh hm;
  hm.order = p;
  hm.distribution = d;
  hm.V = mesh.V;
  hm.F = mesh.F;
  hm.E = T.E;
  hm.FE = T.FE;
  hm.face_entity = mesh.face_entity;
  hm.physicals = mesh.physicals;
  hm.edge_nodes.resize(static_cast<Eigen::Index>(T.num_edges()) * hm.nodes_per_edge(), 3);
  hm.face_nodes.resize(static_cast<Eigen::Index>(mesh.num_faces()) * hm.nodes_per_face(), 3);
  return hm;
}

HighOrderMesh make_straight_high_order(const Mesh& mesh, const Topology& T, int p, NodeDistribution d) {
  if (p < 1 || p > 10)
    throw UsageError("make_straight_high_order: order " + std::to_string(p) + " out of range 1..10");
  if (T.FE.rows() != mesh.F.rows() || (mesh.F.rows() > 0 && (mesh.F.cols() != 3 || T.FE.cols() != 3)))
    throw UsageError("make_straight_high_order: topology does not match the mesh (" +
                     std::to_string(T.FE.rows()) + " face-edge rows for " + std::to_string(mesh.F.rows()) +
                     " faces)");
  const int nv = mesh.num_vertices();
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int j = 0; j < 3; ++j)
      if (mesh.F(f, j) < 0 || mesh.F(f, j) >= nv)
        throw InputError("face " + std::to_string(f), "vertex index " + std::to_string(mesh.F(f, j)) +
                                                           " out of range 0.." + std::to_string(nv - 1));
  if (mesh.face_entity.size() != 0 && mesh.face_entity.size() != mesh.F.rows())
    throw InputError("face_entity", "has " + std::to_string(mesh.face_entity.size()) + " entries for " +
                                        std::to_string(mesh.F.rows()) + " faces");

  HighOrderMesh hm = high_order_frame(mesh, T, p, d);

  // Edge nodes: the 1D distribution walked from E(e,0) to E(e,1). The triangle's Lobatto nodes
  // on its edges are exactly these 1D points, so faces and edges agree.
  const int ne = T.num_edges(), npe = p - 1;
  const Eigen::VectorXd t = line_reference_nodes(p, d);
  for (int e = 0; e < ne; ++e) {
    const Eigen::RowVector3d a = mesh.V.row(T.E(e, 0)), b = mesh.V.row(T.E(e, 1));
    for (int k = 1; k < p; ++k) hm.edge_nodes.row(static_cast<Eigen::Index>(e) * npe + k - 1) = a + t[k] * (b - a);
  }

  // Face nodes: the reference interior nodes (rows 3p.. in Gmsh order) mapped affinely.
  const int npf = hm.nodes_per_face();
  if (npf > 0) {
    const Eigen::MatrixXd ref = triangle_reference_nodes(p, d);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      const Eigen::RowVector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
      for (int k = 0; k < npf; ++k) {
        const double u = ref(3 * p + k, 0), v = ref(3 * p + k, 1);
        hm.face_nodes.row(f * npf + k) = a + u * (b - a) + v * (c - a);
      }
    }
  }
  return hm;
}

void element_node_indices(const HighOrderMesh& hm, int f, int* out) {
  const int p = hm.order, npe = p - 1, npf = hm.nodes_per_face();
  const int nv = static_cast<int>(hm.V.rows());
  const int ne = static_cast<int>(hm.E.rows());
  int n = 0;
  for (int j = 0; j < 3; ++j) out[n++] = hm.F(f, j);
  for (int j = 0; j < 3; ++j) {
    const int e = hm.FE(f, j);
    const int base = nv + e * npe;
    // Edge j runs from corner j to corner j+1; Gmsh lists its nodes in that direction.
    if (hm.E(e, 0) == hm.F(f, j))
      for (int k = 0; k < npe; ++k) out[n++] = base + k;
    else
      for (int k = npe - 1; k >= 0; --k) out[n++] = base + k;
  }
  const int fbase = nv + ne * npe + f * npf;
  for (int k = 0; k < npf; ++k) out[n++] = fbase + k;
}

Eigen::Vector3d node_position(const HighOrderMesh& hm, int g) {
  const int nv = static_cast<int>(hm.V.rows()), ned = static_cast<int>(hm.edge_nodes.rows());
  if (g < nv) return hm.V.row(g).transpose();
  if (g < nv + ned) return hm.edge_nodes.row(g - nv).transpose();
  return hm.face_nodes.row(g - nv - ned).transpose();
}

void set_node_position(HighOrderMesh& hm, int g, const Eigen::Vector3d& x) {
  const int nv = static_cast<int>(hm.V.rows()), ned = static_cast<int>(hm.edge_nodes.rows());
  if (g < nv) throw UsageError("set_node_position: node " + std::to_string(g) + " is a vertex");
  if (g < nv + ned) hm.edge_nodes.row(g - nv) = x.transpose();
  else hm.face_nodes.row(g - nv - ned) = x.transpose();
}

Eigen::MatrixXd element_nodes(const HighOrderMesh& hm, int f) {
  const int p = hm.order;
  if (p < 1 || p > 10) throw UsageError("element_nodes: order " + std::to_string(p) + " out of range 1..10");
  const int n = triangle_node_count(p);
  int idx[66];  // order <= 10
  element_node_indices(hm, f, idx);
  Eigen::MatrixXd X(n, 3);
  for (int k = 0; k < n; ++k) X.row(k) = node_position(hm, idx[k]).transpose();
  return X;
}

Eigen::MatrixXd all_nodes(const HighOrderMesh& hm) {
  Eigen::MatrixXd X(hm.V.rows() + hm.edge_nodes.rows() + hm.face_nodes.rows(), 3);
  Eigen::Index r = 0;
  for (const Eigen::MatrixXd* M : {&hm.V, &hm.edge_nodes, &hm.face_nodes})
    if (M->rows() > 0) {
      X.middleRows(r, M->rows()) = *M;
      r += M->rows();
    }
  return X;
}

}  // namespace hocurve
