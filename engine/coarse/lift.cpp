#include "engine/coarse/lift.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/place_nodes.hpp"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hocurve {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

template <class F>
void parallel(int n, F&& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) body(i);
  });
}

/// Coarse feature edges: the open boundary, entity borders, and edges that the map lays onto a
/// dense feature curve (tested at the edge midpoint; the decimation moves feature vertices only
/// along their curve, so a coarse edge between two curve vertices either follows the curve or
/// crosses a smooth region).
std::vector<char> coarse_feature_edges(const Mesh& coarse, const Topology& Tc, const DecimateResult& dec,
                                       const DenseSurface& S, long long& clamped) {
  const int ne = Tc.num_edges();
  std::vector<char> feat(ne, 0);
  std::vector<int> clamps(ne, 0);
  const auto& vf = S.features.vertex_feature;
  const auto& ef = S.features.edge_feature;
  parallel(ne, [&](int e) {
    const auto& faces = Tc.edge_faces[e];
    if (faces.size() != 2) { feat[e] = 1; return; }
    if (coarse.entity_of(faces[0]) != coarse.entity_of(faces[1])) { feat[e] = 1; return; }
    const int a = Tc.E(e, 0), b = Tc.E(e, 1);
    // Both ends on a curve in the decimation too: a vertex that the decimation moved freely (its
    // origin on a soft crease it dropped) is not on the dense curve.
    if (vf.empty() || !vf[dec.coarse_vertex_origin[a]] || !vf[dec.coarse_vertex_origin[b]] ||
        !dec.coarse_vertex_feature[a] || !dec.coarse_vertex_feature[b])
      return;
    const int f = faces[0];
    Eigen::Vector3d xi = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j)
      if (coarse.F(f, j) == a || coarse.F(f, j) == b) xi[j] = 0.5;
    MapQueryStats st;
    const SurfacePoint sp = coarse_to_fine(dec.map, f, xi, &st);
    clamps[e] = static_cast<int>(st.clamped);
    const double tol = 1e-7;
    for (int j = 0; j < 3; ++j) {
      if (sp.bary[j] > tol) continue;
      // The point lies on the dense edge opposite corner j (edge (j+1)%3 joins corners j+1, j+2).
      if (ef[S.T.FE(sp.face, (j + 1) % 3)]) feat[e] = 1;
      // On a dense vertex: a curve vertex counts too.
      for (int k = 1; k <= 2; ++k)
        if (sp.bary[(j + k) % 3] > 1 - tol && vf[S.mesh->F(sp.face, (j + k) % 3)]) feat[e] = 1;
    }
  });
  for (int c : clamps) clamped += c;
  return feat;
}

/// A coarse fit is sane when it moves no point of its wedge's faces by more than
/// max_offset x sqrt(2 area) (as the dense fits' sanity bound).
bool coarse_fit_sane(const Mesh& m, const Wedges& W, int w, const LocalFit& fit, double max_offset) {
  if (!fit.c.allFinite()) return false;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double limit = max_offset * std::sqrt((b - a).cross(c - a).norm());
    for (int j = 0; j <= 4; ++j)
      for (int k = 0; j + k <= 4; ++k) {
        const Eigen::Vector3d x = a + (j / 4.0) * (b - a) + (k / 4.0) * (c - a);
        if (!((fit.project(x) - x).norm() <= limit)) return false;
      }
  }
  return true;
}

struct CoarseFit {
  LocalFit fit;
  int rings = 0;
};

/// The MLS fit of coarse wedge w to the dense vertices mapped into its coarse rings.
CoarseFit fit_coarse_wedge(const Mesh& fine, const Mesh& coarse, const Topology& Tc, const Wedges& Wc,
                           const CoarseMap& map, int w, const LiftOptions& opt) {
  const int v = Wc.wedge_vertex[w];
  const int p = opt.order;
  const Eigen::Vector3d o = coarse.V.row(v).transpose();
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  double hsum = 0;
  int hcount = 0;
  for (int i = Wc.wedge_start[w]; i < Wc.wedge_start[w + 1]; ++i) {
    const int f = Wc.wedge_faces[i];
    int j = 0;
    while (coarse.F(f, j) != v) ++j;
    const Eigen::Vector3d a = coarse.V.row(coarse.F(f, (j + 1) % 3)).transpose() - o;
    const Eigen::Vector3d c = coarse.V.row(coarse.F(f, (j + 2) % 3)).transpose() - o;
    n += a.cross(c);
    hsum += a.norm() + c.norm();
    hcount += 2;
  }
  const double h = hcount ? std::max(hsum / hcount, 1e-300) : 1.0;
  n = n.norm() > 0 ? n.normalized() : Eigen::Vector3d::UnitZ();
  const int need = static_cast<int>(std::ceil(opt.fit.points_per_coef * fit_coefficients(p)));
  std::vector<int> pts;
  CoarseFit out;
  for (int r = 1; r <= std::max(1, opt.max_rings); ++r) {
    StencilOptions so;
    so.min_rings = so.max_rings = r;
    so.target_points = 0;
    so.max_points = 1 << 30;
    const Stencil st = grow_stencil(coarse, Tc, Wc, w, so);
    pts.clear();
    for (int cf : st.faces) {
      auto [b, e] = map.fine_vertices_in(cf);
      for (const int* it = b; it != e; ++it)
        if ((fine.V.row(*it).transpose() - o).norm() > 1e-12 * h) pts.push_back(*it);
    }
    out.rings = r;
    if (static_cast<int>(pts.size()) >= need) break;
  }
  const int k = static_cast<int>(pts.size());
  Eigen::MatrixXd P(k, 3);
  Eigen::VectorXd wt(k);
  const double sigma = opt.coarse_sigma_factor * h;
  for (int i = 0; i < k; ++i) {
    P.row(i) = fine.V.row(pts[i]);
    const double d2 = (P.row(i).transpose() - o).squaredNorm();
    wt[i] = std::exp(-d2 / (2 * sigma * sigma));
  }
  for (int d = p; d >= 1; --d) {
    out.fit = solve_height_fit(o, n, h, P, wt, d, opt.fit);
    out.fit.requested_degree = p;
    if (coarse_fit_sane(coarse, Wc, w, out.fit, opt.fit.max_offset)) return out;
  }
  out.fit.identity = true;  // nothing sane: the corner keeps the straight triangles
  out.fit.degree = 0;
  return out;
}

/// Shrinks the snapped nodes of invalid elements toward their fit-blend positions
/// (x = fit + s (snapped - fit), s *= shrink per round, per edge and face so that shared edge
/// nodes stay conforming), re-checking the touched elements. Returns the elements touched.
long long fall_back_to_fits(HighOrderMesh& hm, const Eigen::MatrixXd& edge_fit, const Eigen::MatrixXd& face_fit,
                            const ValidityOptions& vopt) {
  const int nf = hm.num_faces(), ne = static_cast<int>(hm.E.rows());
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  const Eigen::MatrixXd edge_snap = hm.edge_nodes, face_snap = hm.face_nodes;
  std::vector<double> se(ne, 1.0), sf(nf, 1.0);
  std::vector<char> touched(nf, 0);
  const JacobianBasis basis(hm.order);
  std::vector<char> bad(nf, 0), check(nf, 1);
  std::vector<std::vector<int>> edge_faces(ne);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) edge_faces[hm.FE(f, j)].push_back(f);
  for (int round = 0; round < 12; ++round) {
    parallel(nf, [&](int f) {
      if (check[f]) bad[f] = !check_element(basis, element_nodes(hm, f), vopt).valid;
    });
    std::vector<char> edge_changed(ne, 0);
    bool any = false;
    for (int f = 0; f < nf; ++f) {
      check[f] = 0;
      if (!bad[f]) continue;
      any = true;
      touched[f] = 1;
      const double k = round == 11 ? 0.0 : 0.6;
      sf[f] *= k;
      for (int j = 0; j < 3; ++j) {
        const int e = hm.FE(f, j);
        if (!edge_changed[e]) se[e] *= k, edge_changed[e] = 1;
      }
    }
    if (!any) break;
    for (int e = 0; e < ne; ++e) {
      if (!edge_changed[e]) continue;
      for (int k = 0; k < npe; ++k) {
        const Eigen::Index r = static_cast<Eigen::Index>(e) * npe + k;
        hm.edge_nodes.row(r) = edge_fit.row(r) + se[e] * (edge_snap.row(r) - edge_fit.row(r));
      }
      for (int g : edge_faces[e]) check[g] = 1;
    }
    for (int f = 0; f < nf; ++f)
      if (bad[f]) {
        check[f] = 1;
        for (int k = 0; k < npf; ++k) {
          const Eigen::Index r = static_cast<Eigen::Index>(f) * npf + k;
          hm.face_nodes.row(r) = face_fit.row(r) + sf[f] * (face_snap.row(r) - face_fit.row(r));
        }
      }
  }
  long long n = 0;
  for (char t : touched) n += t;
  return n;
}

}  // namespace

FeatureOptions feature_options(const DecimateOptions& d) {
  FeatureOptions f;
  f.angle_deg = d.preserve_features ? d.feature_angle_deg : 180.0;
  f.weak_angle_deg = d.preserve_features ? f.weak_angle_deg : 180.0;
  f.corner_angle_deg = d.corner_angle_deg;
  f.entity_borders = d.preserve_features && d.entity_borders;
  f.min_dangling_edges = d.min_feature_curve_edges;
  return f;
}

LiftResult lift_coarse(const Mesh& fine, const DecimateResult& dec, const LiftOptions& opt) {
  if (opt.order < 2 || opt.order > 6) throw UsageError("lift order " + std::to_string(opt.order) + " is outside 2..6");
  const CoarseMap& map = dec.map;
  if (static_cast<int>(map.vertex_coarse_face.size()) != fine.num_vertices() ||
      static_cast<int>(map.cf_start.size()) != dec.coarse.num_faces() + 1 ||
      static_cast<int>(dec.coarse_vertex_feature.size()) != dec.coarse.num_vertices())
    throw UsageError("lift_coarse needs the decimation's map of this input (build_map = true)");
  if (dec.coarse.num_faces() == 0) throw InputError("", "the coarse mesh has no triangles");
  const auto t_all = Clock::now();
  auto progress = [&](const char* stage, double f) {
    if (opt.progress) opt.progress(stage, f);
  };
  const int p = opt.order;
  LiftResult R;
  R.bbox_diagonal = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();

  // 1. The dense reference surface.
  progress("dense fits", 0.0);
  DenseSurfaceOptions dso;
  dso.degree = opt.dense_degree;
  dso.max_lift = opt.max_lift;
  dso.features = opt.features;
  dso.fit = opt.fit;
  const DenseSurface S = build_dense_surface(fine, dso);
  R.dense_feature_edges = S.features.feature_edges;
  R.dense_corners = S.features.corners;
  R.dense_fits = S.fits;
  R.dense_curve_fits = S.curves.fitted;
  R.dense_support = S.support_used;
  R.seconds_dense = S.seconds;

  // 2. Coarse topology, features, and corners on the dense surface.
  progress("coarse features", 0.45);
  auto t0 = Clock::now();
  Mesh coarse = dec.coarse;
  const int ncv = coarse.num_vertices(), ncf = coarse.num_faces();
  const Topology Tc = build_topology(coarse.F, ncv);
  R.vertices = ncv, R.faces = ncf, R.edges = Tc.num_edges();
  const std::vector<char> cfeat = coarse_feature_edges(coarse, Tc, dec, S, R.map_clamped);
  std::vector<char> on_curve(ncv, 0);
  for (int e = 0; e < Tc.num_edges(); ++e)
    if (cfeat[e]) on_curve[Tc.E(e, 0)] = on_curve[Tc.E(e, 1)] = 1, ++R.coarse_feature_edges;
  std::vector<int> clamps(ncv, 0), steps(ncv, 0);
  parallel(ncv, [&](int v) {
    const int o = dec.coarse_vertex_origin[v];
    if (S.features.vertex_corner[o] && dec.coarse_vertex_feature[v]) {  // else moved off it
      coarse.V.row(v) = fine.V.row(o);
      return;
    }
    auto [fb, fe] = Tc.faces_of(v);
    if (fb == fe) return;
    const int f = *fb;
    Eigen::Vector3d xi = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j)
      if (dec.coarse.F(f, j) == v) xi[j] = 1;
    MapQueryStats st;
    const SurfacePoint sp = coarse_to_fine(map, f, xi, &st);
    const Eigen::Vector3d x = dec.coarse.V.row(v).transpose();
    const DenseProjection P =
        on_curve[v] ? project_to_dense_curve(S, sp.face, x) : project_to_dense_surface(S, sp.face, x);
    coarse.V.row(v) = P.lifted.transpose();
    clamps[v] = static_cast<int>(st.clamped);
    steps[v] = P.steps;
  });
  for (int v = 0; v < ncv; ++v) R.map_clamped += clamps[v], R.walk_steps += steps[v];
  R.nodes += ncv;

  // 3. Coarse fits.
  progress("coarse fits", 0.5);
  const Wedges Wc = build_wedges(coarse, Tc, cfeat);
  R.coarse_wedges = Wc.num_wedges();
  std::vector<CoarseFit> cfits(Wc.num_wedges());
  parallel(Wc.num_wedges(), [&](int w) { cfits[w] = fit_coarse_wedge(fine, coarse, Tc, Wc, map, w, opt); });
  std::vector<LocalFit> fits(cfits.size());
  R.coarse_degree_histogram.assign(p + 1, 0);
  R.coarse_min_points = cfits.empty() ? 0 : std::numeric_limits<int>::max();
  double sum_points = 0;
  for (size_t w = 0; w < cfits.size(); ++w) {
    fits[w] = cfits[w].fit;
    ++R.coarse_degree_histogram[std::clamp(fits[w].degree, 0, p)];
    R.coarse_min_points = std::min(R.coarse_min_points, fits[w].points);
    sum_points += fits[w].points;
    R.coarse_grown += cfits[w].rings > 1;
  }
  R.coarse_mean_points = cfits.empty() ? 0 : sum_points / cfits.size();
  R.seconds_coarse_fits = since(t0);

  // 4. High-order nodes: blend of the coarse fits, snapped onto the dense surface.
  progress("placement", 0.6);
  t0 = Clock::now();
  R.mesh = high_order_frame(coarse, Tc, p, opt.distribution);
  HighOrderMesh& hm = R.mesh;
  const int ne = Tc.num_edges(), npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  const Eigen::VectorXd line = line_reference_nodes(p, opt.distribution);
  const Eigen::MatrixXd tri = triangle_reference_nodes(p, opt.distribution);
  struct NodeStats {
    double max = 0, sum2 = 0;
    long long clamped = 0, steps = 0, curve = 0, ray_failed = 0;
  };
  // One node: blend, then snap. Returns the node and updates the item's stats.
  // The fit-blend positions, kept: invalid snapped elements fall back toward them first.
  Eigen::MatrixXd edge_fit(hm.edge_nodes.rows(), 3), face_fit(hm.face_nodes.rows(), 3);
  auto place = [&](int f, const Eigen::Vector3d& xi, bool curve, NodeStats& ns, Eigen::Vector3d& x0) -> Eigen::Vector3d {
    x0 = blend_point(coarse, Wc, fits, f, xi);
    if (!opt.refine) return x0;
    MapQueryStats st;
    const SurfacePoint sp = coarse_to_fine(map, f, xi, &st);
    DenseProjection P;
    if (curve) {
      P = project_to_dense_curve(S, sp.face, x0);
    } else if (opt.projection == LiftOptions::Projection::Closest) {
      P = project_to_dense_surface(S, sp.face, x0);
    } else {
      // Along the blend of the corner fits' normals (only the edge's two ends on an edge: conforming).
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      double hf = 0;
      for (int j = 0; j < 3; ++j) {
        n += xi[j] * fits[Wc.corner_wedge(f, j)].n;
        hf += (coarse.V.row(coarse.F(f, j)) - coarse.V.row(coarse.F(f, (j + 1) % 3))).norm() / 3;
      }
      bool ok = false;
      P = n.norm() > 0 ? project_along_dense_surface(S, sp.face, x0, n.normalized(), opt.max_ray * hf, ok)
                       : project_to_dense_surface(S, sp.face, x0);
      ns.ray_failed += !ok;
    }
    const double d = (P.lifted - x0).norm();
    ns.max = std::max(ns.max, d);
    ns.sum2 += d * d;
    ns.clamped += st.clamped;
    ns.steps += P.steps;
    ns.curve += curve;
    return P.lifted;
  };
  std::vector<NodeStats> edge_stats(ne), face_stats(ncf);
  parallel(ne, [&](int e) {
    const int f = Tc.edge_faces[e][0];
    int ja = 0, jb = 0;
    for (int j = 0; j < 3; ++j) {
      if (coarse.F(f, j) == Tc.E(e, 0)) ja = j;
      if (coarse.F(f, j) == Tc.E(e, 1)) jb = j;
    }
    for (int k = 1; k < p; ++k) {
      Eigen::Vector3d xi = Eigen::Vector3d::Zero();
      xi[ja] = 1 - line[k];
      xi[jb] = line[k];
      Eigen::Vector3d x0;
      const Eigen::Index r = static_cast<Eigen::Index>(e) * npe + k - 1;
      hm.edge_nodes.row(r) = place(f, xi, cfeat[e], edge_stats[e], x0).transpose();
      edge_fit.row(r) = x0.transpose();
    }
  });
  if (npf > 0)
    parallel(ncf, [&](int f) {
      for (int k = 0; k < npf; ++k) {
        const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
        Eigen::Vector3d x0;
        const Eigen::Index r = static_cast<Eigen::Index>(f) * npf + k;
        hm.face_nodes.row(r) = place(f, Eigen::Vector3d(1 - u - v, u, v), false, face_stats[f], x0).transpose();
        face_fit.row(r) = x0.transpose();
      }
    });
  double sum2 = 0;
  for (const auto* stats : {&edge_stats, &face_stats})
    for (const NodeStats& ns : *stats) {
      R.refine_max = std::max(R.refine_max, ns.max);
      sum2 += ns.sum2;
      R.map_clamped += ns.clamped;
      R.walk_steps += ns.steps;
      R.curve_nodes += ns.curve;
      R.ray_failed += ns.ray_failed;
    }
  const long long ho_nodes = static_cast<long long>(ne) * npe + static_cast<long long>(ncf) * npf;
  R.nodes += ho_nodes;
  if (R.bbox_diagonal > 0) {
    R.refine_max /= R.bbox_diagonal;
    R.refine_rms = ho_nodes ? std::sqrt(sum2 / ho_nodes) / R.bbox_diagonal : 0;
  }
  R.seconds_placement = since(t0);

  // 5. Validity. Snapped nodes interpolate the dense data, noise included (scans): where that
  // folds an element, its nodes go back toward the smooth coarse-fit blend first; then the
  // check and repair of dense curving (toward the straight triangles) as the final guarantee.
  progress("validity", 0.9);
  t0 = Clock::now();
  if (opt.refine && opt.repair) R.fit_fallback_elements = fall_back_to_fits(hm, edge_fit, face_fit, opt.validity);
  R.validity = opt.repair ? repair_validity(hm, opt.validity) : check_validity(hm, opt.validity);
  R.seconds_validity = since(t0);
  R.seconds_total = since(t_all);
  progress("done", 1.0);
  return R;
}

}  // namespace hocurve
