// In-surface untangling on a flat mesh, where the surface is the plane and every figure is known.
#include "engine/core/topology.hpp"
#include "engine/curving/untangle.hpp"
#include "engine/highorder/high_order_mesh.hpp"
#include "engine/highorder/validity.hpp"

#include <doctest/doctest.h>

#include <vector>

using namespace hocurve;

namespace {

/// A needle A B C (C 0.1 above the middle of A B) between a face below A B and two above it, in
/// the plane z = 0; edge A B is a feature whose P4 nodes bulge toward C on a cubic, at most `bulge`
/// a third of the way along (a rim that turns hardest near its end, as a hole's rim meeting a
/// crease): leaving A at slope 6.75 bulge, steeper than A C's 0.2 from 0.03 on, it folds the needle
/// there.
struct Needle {
  Mesh mesh;
  Topology T;
  std::vector<char> edge_feature;
  std::vector<int> planar;
  HighOrderMesh hm;
  int feature_edge = -1;
  explicit Needle(double bulge) {
    mesh.V.resize(5, 3);
    mesh.V << 0, 0, 0,  // A
        1, 0, 0,        // B
        0.5, 0.1, 0,    // C
        0.5, -0.5, 0,   // D
        0.5, 1, 0;      // E
    mesh.F.resize(4, 3);
    mesh.F << 0, 3, 1, 0, 1, 2, 0, 2, 4, 2, 1, 4;
    T = build_topology(mesh.F, 5);
    hm = make_straight_high_order(mesh, T, 4);
    edge_feature.assign(T.num_edges(), 0);
    for (int e = 0; e < T.num_edges(); ++e)
      if (T.E(e, 0) == 0 && T.E(e, 1) == 1) feature_edge = e;
    edge_feature[feature_edge] = 1;
    for (int k = 0; k < 3; ++k) {
      const double t = (k + 1) / 4.0;
      hm.edge_nodes.row(feature_edge * 3 + k) << t, 6.75 * bulge * t * (1 - t) * (1 - t), 0;
    }
    planar.assign(4, 0);  // flat: nodes go back onto the faces' plane
  }
  UntangleResult untangle() {
    SurfaceOfFaces surface;
    surface.mesh = &mesh;
    surface.planar = &planar;
    return untangle_in_surface(T, edge_feature, surface, ValidityOptions{}, hm);
  }
};

}  // namespace

TEST_CASE("untangle_in_surface: a needle folded by its feature side is made valid, the side kept") {
  Needle n(0.04);  // leaves A at slope 0.27, A C at 0.2
  REQUIRE(check_validity(n.hm).invalid_before == 1);
  const Eigen::MatrixXd feature_nodes = n.hm.edge_nodes.middleRows(n.feature_edge * 3, 3);
  const UntangleResult r = n.untangle();
  CHECK(r.targets == 1);
  CHECK(r.kept == 1);
  CHECK(r.cleared == 1);
  const ValidityReport v = check_validity(n.hm);
  CHECK(v.invalid_before == 0);
  CHECK(v.min_scaled_jacobian > 0.01);  // above the quality floor too
  CHECK(n.hm.edge_nodes.middleRows(n.feature_edge * 3, 3) == feature_nodes);
  CHECK(n.hm.edge_nodes.col(2).cwiseAbs().maxCoeff() < 1e-15);  // still in the plane
  CHECK(n.hm.face_nodes.col(2).cwiseAbs().maxCoeff() < 1e-15);
}

TEST_CASE("untangle_in_surface: a side bulging past the third corner cannot be untangled and is left") {
  // Bulge 0.3: the side passes 0.101 above C's middle, beyond C, which stays put, so no in-surface
  // move helps; the patch is not kept and the nodes are as they were (the repair's to pull).
  Needle n(0.3);
  const HighOrderMesh before = n.hm;
  const UntangleResult r = n.untangle();
  CHECK(r.targets >= 1);
  CHECK(r.kept == 0);
  CHECK(n.hm.edge_nodes == before.edge_nodes);
  CHECK(n.hm.face_nodes == before.face_nodes);
}

TEST_CASE("untangle_in_surface: a valid mesh is left as it is") {
  Needle n(0.0);
  const HighOrderMesh before = n.hm;
  const UntangleResult r = n.untangle();
  CHECK(r.targets == 0);
  CHECK(n.hm.edge_nodes == before.edge_nodes);
}
