#include "engine/coarse/lift.hpp"

#include "engine/coarse/closest_candidate.hpp"
#include "engine/coarse/surface_distance.hpp"

#include "engine/core/error.hpp"
#include "engine/core/stopwatch.hpp"
#include "engine/curving/place_nodes.hpp"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <algorithm>
#include <optional>
#include <cmath>
#include <limits>
#include <functional>

namespace hocurve {

namespace {

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
    // origin on a soft crease it dropped) is not on the dense curve. A split vertex (no origin)
    // marked as a feature vertex was put on it.
    auto on_dense_curve = [&](int v) {
      const int o = dec.coarse_vertex_origin[v];
      return dec.coarse_vertex_feature[v] && (o < 0 || vf[o]);
    };
    if (vf.empty() || !on_dense_curve(a) || !on_dense_curve(b)) return;
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

/// Unit normals of the straight triangles, #F x 3.
Eigen::MatrixXd unit_face_normals(const Mesh& m) {
  Eigen::MatrixXd n(m.num_faces(), 3);
  for (int f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    n.row(f) = (b - a).cross(c - a).normalized().transpose();
  }
  return n;
}

/// A coarse fit is sane when it moves no point of its wedge's faces by more than
/// fit_offset_limit (as the dense fits' sanity bound).
bool coarse_fit_sane(const Mesh& m, const Wedges& W, int w, const LocalFit& fit, const FitOptions& opt) {
  if (!fit.c.allFinite()) return false;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i) {
    const int f = W.wedge_faces[i];
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double limit = fit_offset_limit(a, b, c, opt);
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
    if (coarse_fit_sane(coarse, Wc, w, out.fit, opt.fit)) return out;
  }
  out.fit.identity = true;  // nothing sane: the corner keeps the straight triangles
  out.fit.degree = 0;
  return out;
}

/// Which node group of element f (nodes in Gmsh order) alone makes it valid when it goes back to
/// its fit-blend positions `fit`: 0..2 = the nodes of edge j, 3 = the face nodes, -1 = none of
/// them alone (then every node goes back).
int offending_group(const JacobianBasis& basis, const Eigen::MatrixXd& nodes, const Eigen::MatrixXd& fit, int npe,
                    const ValidityOptions& vopt) {
  const int npf = static_cast<int>(nodes.rows()) - 3 - 3 * npe;
  Eigen::MatrixXd x = nodes;
  auto valid_with = [&](int lo, int n) {
    x.middleRows(lo, n) = fit.middleRows(lo, n);
    const bool ok = check_element(basis, x, vopt).valid;
    x.middleRows(lo, n) = nodes.middleRows(lo, n);
    return ok;
  };
  // The face nodes first: they belong to this element only.
  if (npf > 0 && valid_with(3 + 3 * npe, npf)) return 3;
  for (int j = 0; j < 3; ++j)
    if (valid_with(3 + j * npe, npe)) return j;
  return -1;
}

/// A node's position at shrink factor s (1: snapped, 0: fallback target), by storage row.
using NodeAt = std::function<Eigen::RowVector3d(Eigen::Index row, double s)>;

/// Shrinks the snapped nodes of invalid elements toward their fit-blend positions
/// (x = fit + s (snapped - fit), s *= shrink per round, per edge and face so that shared edge
/// nodes stay conforming), re-checking the touched elements; edge_at / face_at, when given, place
/// the nodes at s instead (edge_fit / face_fit are then their positions at s = 0). With
/// offending_only, an element that one node group (its face nodes, or one edge's) makes valid
/// shrinks only that group: the others stay on the dense surface. Returns the elements touched.
long long fall_back_to_fits(HighOrderMesh& hm, const Eigen::MatrixXd& edge_fit, const Eigen::MatrixXd& face_fit,
                            bool offending_only, const ValidityOptions& vopt, const NodeAt& edge_at = {},
                            const NodeAt& face_at = {}) {
  const int nf = hm.num_faces(), ne = static_cast<int>(hm.E.rows());
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  const Eigen::MatrixXd edge_snap = hm.edge_nodes, face_snap = hm.face_nodes;
  HighOrderMesh fit_mesh = hm;
  fit_mesh.edge_nodes = edge_fit, fit_mesh.face_nodes = face_fit;
  std::vector<double> se(ne, 1.0), sf(nf, 1.0);
  std::vector<char> touched(nf, 0);
  const JacobianBasis basis(hm.order);
  std::vector<char> bad(nf, 0), check(nf, 1);
  std::vector<int> group(nf, -1);
  std::vector<std::vector<int>> edge_faces(ne);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) edge_faces[hm.FE(f, j)].push_back(f);
  for (int round = 0; round < 12; ++round) {
    parallel(nf, [&](int f) {
      if (!check[f]) return;
      const Eigen::MatrixXd x = element_nodes(hm, f);
      bad[f] = !check_element(basis, x, vopt).valid;
      group[f] = bad[f] && offending_only && round < 11 ? offending_group(basis, x, element_nodes(fit_mesh, f), npe, vopt) : -1;
    });
    std::vector<char> edge_changed(ne, 0), face_changed(nf, 0);
    bool any = false;
    for (int f = 0; f < nf; ++f) {
      check[f] = 0;
      if (!bad[f]) continue;
      any = true;
      touched[f] = 1;
      const double k = round == 11 ? 0.0 : 0.6;
      if (group[f] < 0 || group[f] == 3) sf[f] *= k, face_changed[f] = 1;
      for (int j = 0; j < 3; ++j) {
        const int e = hm.FE(f, j);
        if (!edge_changed[e] && (group[f] < 0 || group[f] == j)) se[e] *= k, edge_changed[e] = 1;
      }
    }
    if (!any) break;
    for (int e = 0; e < ne; ++e) {
      if (!edge_changed[e]) continue;
      for (int k = 0; k < npe; ++k) {
        const Eigen::Index r = static_cast<Eigen::Index>(e) * npe + k;
        hm.edge_nodes.row(r) = edge_at ? edge_at(r, se[e]) : edge_fit.row(r) + se[e] * (edge_snap.row(r) - edge_fit.row(r));
      }
      for (int g : edge_faces[e]) check[g] = 1;
    }
    for (int f = 0; f < nf; ++f)
      if (face_changed[f]) {
        check[f] = 1;
        for (int k = 0; k < npf; ++k) {
          const Eigen::Index r = static_cast<Eigen::Index>(f) * npf + k;
          hm.face_nodes.row(r) = face_at ? face_at(r, sf[f]) : face_fit.row(r) + sf[f] * (face_snap.row(r) - face_fit.row(r));
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
  // Coarse fillets stay sharp here: decimating a two-chord fillet along its middle row is as good
  // as across it, and the re-decimation search moved both ways when a scan lost a few such edges
  // (bench_lift real at 4%: armadillo 0.338 -> 0.443%, spot 0.571 -> 0.435%; skull 5% 0.536 -> 0.622%).
  f.fillet_max_deg = 0;
  return f;
}

DenseSurfaceOptions dense_surface_options(const LiftOptions& opt) {
  DenseSurfaceOptions dso;
  dso.degree = opt.dense_degree;
  dso.max_lift = opt.max_lift;
  dso.features = opt.features;
  dso.fit = opt.fit;
  dso.long_edges = opt.long_edges;
  return dso;
}

LiftResult lift_coarse(const Mesh& fine, const DecimateResult& dec, const LiftOptions& opt, const DenseSurface* dense) {
  if (opt.order < 1 || opt.order > 6) throw UsageError("lift order " + std::to_string(opt.order) + " is outside 1..6");
  const CoarseMap& map = dec.map;
  if (static_cast<int>(map.vertex_coarse_face.size()) != fine.num_vertices() ||
      static_cast<int>(map.cf_start.size()) != dec.coarse.num_faces() + 1 ||
      static_cast<int>(dec.coarse_vertex_feature.size()) != dec.coarse.num_vertices() ||
      dec.coarse_vertex_pinned.size() != dec.coarse_vertex_feature.size())
    throw UsageError("lift_coarse needs the decimation's map of this input (build_map = true)");
  if (dec.coarse.num_faces() == 0) throw InputError("", "the coarse mesh has no triangles");
  const auto t_all = Clock::now();
  auto progress = [&](const char* stage, double f) {
    if (opt.progress) opt.progress(stage, f);
  };
  const int p = opt.order;
  LiftResult R;
  R.bbox_diagonal = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();

  if (p == 1) {
    // The straight decimated triangles as they are: their vertices sit where the quadrics put them,
    // on both sides of the dense surface; moved onto it (as the curved lift does) a convex part's
    // triangles would all lie inside it (icosphere 5120 -> 320: 0.0176 -> 0.0264 off the sphere).
    const Topology Tc = build_topology(dec.coarse.F, dec.coarse.num_vertices());
    R.vertices = dec.coarse.num_vertices(), R.faces = dec.coarse.num_faces(), R.edges = Tc.num_edges();
    R.mesh = high_order_frame(dec.coarse, Tc, 1, opt.distribution);
    R.validity = check_validity(R.mesh, opt.validity);
    R.seconds_total = seconds_since(t_all);
    progress("done", 1.0);
    return R;
  }

  // 1. The dense reference surface.
  progress("dense fits", 0.0);
  std::optional<DenseSurface> own;
  if (!dense) own = build_dense_surface(fine, dense_surface_options(opt));
  const DenseSurface& S = dense ? *dense : *own;
  R.dense_feature_edges = S.features.feature_edges;
  R.dense_corners = S.features.corners;
  R.dense_fits = S.fits;
  R.dense_curve_fits = S.curves.fitted;
  R.dense_support = S.support_used;
  R.seconds_dense = dense ? 0.0 : S.seconds;  // a given surface was paid for by the caller

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
  R.coarse_edge_feature = cfeat;
  std::vector<int> clamps(ncv, 0), steps(ncv, 0);
  parallel(ncv, [&](int v) {
    const int o = dec.coarse_vertex_origin[v];
    if ((o >= 0 && S.features.vertex_corner[o] && dec.coarse_vertex_feature[v]) || dec.coarse_vertex_pinned[v]) {  // else moved off it
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
  R.seconds_coarse_fits = seconds_since(t0);

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
  // The ray from x0 along n (not normalized; 0: closest point) onto the dense surface, started
  // where the map sends (f, xi); ok = false when it fell back to the closest point.
  auto ray_snap = [&](int f, const Eigen::Vector3d& xi, const Eigen::Vector3d& x0, const Eigen::Vector3d& n,
                      MapQueryStats& st, bool& ok) -> DenseProjection {
    const SurfacePoint sp = coarse_to_fine(map, f, xi, &st);
    double hf = 0;
    for (int j = 0; j < 3; ++j) hf += (coarse.V.row(coarse.F(f, j)) - coarse.V.row(coarse.F(f, (j + 1) % 3))).norm() / 3;
    ok = false;
    return n.norm() > 0 ? project_along_dense_surface(S, sp.face, x0, n.normalized(), opt.max_ray * hf, ok)
                        : project_to_dense_surface(S, sp.face, x0);
  };
  auto place = [&](int f, const Eigen::Vector3d& xi, bool curve, NodeStats& ns, Eigen::Vector3d& x0) -> Eigen::Vector3d {
    x0 = blend_point(coarse, Wc, fits, f, xi);
    if (!opt.refine) return x0;
    MapQueryStats st;
    DenseProjection P;
    if (curve) {
      P = project_to_dense_curve(S, coarse_to_fine(map, f, xi, &st).face, x0);
    } else if (opt.projection == LiftOptions::Projection::Closest) {
      P = project_to_dense_surface(S, coarse_to_fine(map, f, xi, &st).face, x0);
    } else {
      // Along the blend of the corner fits' normals (only the edge's two ends on an edge: conforming).
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) n += xi[j] * fits[Wc.corner_wedge(f, j)].n;
      bool ok = false;
      P = ray_snap(f, xi, x0, n, st, ok);
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
    for (int k = 1; k < p; ++k) {
      const Eigen::Vector3d xi = edge_barycentric(coarse, Tc, e, f, line[k]);
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
  R.seconds_placement = seconds_since(t0);

  // 5. Validity. Snapped nodes interpolate the dense data, noise included (scans): where that
  // folds an element, its nodes re-snap along the straight normals, then go back toward the
  // smooth coarse-fit blend or slide along the dense surface (whichever stays closer to the
  // input); the check and repair of dense curving (toward the straight triangles) is the final
  // guarantee.
  progress("validity", 0.9);
  t0 = Clock::now();
  const Eigen::MatrixXd fn = unit_face_normals(coarse);
  auto edge_normal = [&](int e) {  // the mean of the edge's faces: the same for both, conforming
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (int g : Tc.edge_faces[e]) n += fn.row(g).transpose();
    return n.normalized();
  };
  if (opt.refine && opt.resnap_invalid && opt.projection == LiftOptions::Projection::Ray) {
    // J = (x_u x x_v) . n_straight sees only the in-plane part of the node moves. Where a coarse
    // triangle cuts across curvature, the blended fit normals lean away from n_straight and the
    // snap moves nodes in-plane (invalid elements: as far in-plane as along the normal, up to
    // half an edge), which folds them. Their nodes snap again from the same fit-blend points,
    // along the straight normals: still on the dense surface, with no in-plane move.
    const JacobianBasis basis(p);
    std::vector<char> bad(ncf, 0), redo_edge(ne, 0);
    parallel(ncf, [&](int f) { bad[f] = !check_element(basis, element_nodes(hm, f), opt.validity).valid; });
    for (int f = 0; f < ncf; ++f)
      if (bad[f])
        for (int j = 0; j < 3; ++j) redo_edge[Tc.FE(f, j)] = !cfeat[Tc.FE(f, j)];
    auto resnap = [&](Eigen::MatrixXd::RowXpr node, int f, const Eigen::Vector3d& xi, const Eigen::Vector3d& x0,
                      const Eigen::Vector3d& n) {
      MapQueryStats st;
      bool ok = false;
      const DenseProjection P = ray_snap(f, xi, x0, n, st, ok);
      // Else the first snap stays; so it does when the re-snap lands further from the fit blend
      // than the first snap (measured: such rays lose accuracy, e.g. armadillo 0.766% -> 0.790%).
      if (ok && (P.lifted - x0).norm() <= (node.transpose() - x0).norm()) node = P.lifted.transpose();
    };
    parallel(ne, [&](int e) {
      if (!redo_edge[e]) return;
      const Eigen::Vector3d n = edge_normal(e);
      const int f = Tc.edge_faces[e][0];
      for (int k = 1; k < p; ++k) {
        const Eigen::Index r = static_cast<Eigen::Index>(e) * npe + k - 1;
        resnap(hm.edge_nodes.row(r), f, edge_barycentric(coarse, Tc, e, f, line[k]), edge_fit.row(r).transpose(), n);
      }
    });
    if (npf > 0)
      parallel(ncf, [&](int f) {
        if (!bad[f]) return;
        for (int k = 0; k < npf; ++k) {
          const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
          const Eigen::Index r = static_cast<Eigen::Index>(f) * npf + k;
          resnap(hm.face_nodes.row(r), f, Eigen::Vector3d(1 - u - v, u, v), face_fit.row(r).transpose(),
                 fn.row(f).transpose());
        }
      });
    for (int f = 0; f < ncf; ++f) R.resnapped_elements += bad[f];
  }
  if (!(opt.refine && opt.repair)) {
    R.validity = opt.repair ? repair_validity(hm, opt.validity) : check_validity(hm, opt.validity);
  } else {
    // Candidate ways to make the folded elements valid; each cluster of elements where they differ
    // takes the one closest to the dense input (closest_candidate.hpp). The first: nodes back
    // toward the coarse-fit blend. The others first slide nodes along the dense surface: a node's
    // in-plane offset from its straight position shrinks by s and it goes back onto the dense
    // surface along the straight normal (edge nodes: the mean of their faces'). J sees only the
    // in-plane part, so at s = 0 face nodes give the straight triangle's J, with every node still on
    // the dense surface; edge nodes keep an in-plane offset of their normal move times the sine of
    // half the dihedral angle.
    const Eigen::MatrixXd edge_snap = hm.edge_nodes, face_snap = hm.face_nodes;
    struct Slide {
      bool edges, guard;  // slide edge nodes too; refuse rays that land further from the snap than the fit blend
      bool folded_normal = false;  // edge nodes along the normal of their one folded face, if one is
    };
    std::vector<int> folded_face(ne, -1);  // per edge: its only face that the snap left folded, else -1
    {
      const JacobianBasis basis(p);
      std::vector<char> bad(ncf, 0);
      parallel(ncf, [&](int f) { bad[f] = !check_element(basis, element_nodes(hm, f), opt.validity).valid; });
      for (int e = 0; e < ne; ++e) {
        int n = 0;
        for (int g : Tc.edge_faces[e])
          if (bad[g]) ++n, folded_face[e] = g;
        if (n != 1) folded_face[e] = -1;
      }
    }
    auto slide = [&](const Slide& how, int f, const Eigen::Vector3d& xi, const Eigen::Vector3d& n,
                     const Eigen::Vector3d& snap, const Eigen::Vector3d& fit, double s) -> Eigen::RowVector3d {
      Eigen::Vector3d xs = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) xs += xi[j] * coarse.V.row(coarse.F(f, j)).transpose();
      const Eigen::Vector3d d = snap - xs;
      const Eigen::Vector3d q = xs + s * (d - d.dot(n) * n) + d.dot(n) * n;
      MapQueryStats st;
      bool ok = false;
      const DenseProjection P = ray_snap(f, xi, q, n, st, ok);
      // Without a hit the node keeps its height over the straight plane (nearer the dense surface than
      // the fit blend on the measured meshes); a long ray may have crossed to another sheet (guard).
      if (ok && (!how.guard || (P.lifted - snap).norm() <= (fit - snap).norm())) return P.lifted.transpose();
      return q.transpose();
    };
    auto candidate = [&](const Slide* how, long long& fallback) {
      HighOrderMesh m = hm;
      fallback = 0;
      if (how) {
        const NodeAt edge_at = [&](Eigen::Index r, double s) -> Eigen::RowVector3d {
          const int e = static_cast<int>(r / npe), k = static_cast<int>(r % npe) + 1;
          if (cfeat[e] || !how->edges) return edge_fit.row(r) + s * (edge_snap.row(r) - edge_fit.row(r));
          const int f = Tc.edge_faces[e][0];
          const Eigen::Vector3d n = how->folded_normal && folded_face[e] >= 0 ? Eigen::Vector3d(fn.row(folded_face[e]).transpose()) : edge_normal(e);
          return slide(*how, f, edge_barycentric(coarse, Tc, e, f, line[k]), n,
                       edge_snap.row(r).transpose(), edge_fit.row(r).transpose(), s);
        };
        const NodeAt face_at = [&](Eigen::Index r, double s) -> Eigen::RowVector3d {
          const int f = static_cast<int>(r / npf), k = static_cast<int>(r % npf);
          const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
          return slide(*how, f, Eigen::Vector3d(1 - u - v, u, v), fn.row(f).transpose(), face_snap.row(r).transpose(),
                       face_fit.row(r).transpose(), s);
        };
        Eigen::MatrixXd edge_end(edge_fit.rows(), 3), face_end(face_fit.rows(), 3);
        parallel(static_cast<int>(edge_end.rows()), [&](int r) { edge_end.row(r) = edge_at(r, 0.0); });
        parallel(static_cast<int>(face_end.rows()), [&](int r) { face_end.row(r) = face_at(r, 0.0); });
        fallback += fall_back_to_fits(m, edge_end, face_end, opt.fallback_offending_only, opt.validity, edge_at, face_at);
      }
      fallback += fall_back_to_fits(m, edge_fit, face_fit, opt.fallback_offending_only, opt.validity);
      const ValidityReport rep = repair_validity(m, opt.validity);
      return std::make_pair(std::move(m), rep);
    };
    std::vector<HighOrderMesh> cands;
    auto [m0, rep0] = candidate(nullptr, R.fit_fallback_elements);
    R.validity = rep0;
    cands.push_back(std::move(m0));
    if (opt.slide_candidates) {
      const Slide ways[] = {{true, false}, {true, true}, {false, false}, {true, false, true}};
      for (const Slide& w : ways) {
        long long fb = 0;
        cands.push_back(candidate(&w, fb).first);
      }
      const TriangleGrid grid = build_triangle_grid(fine);
      const ClosestCandidateResult C = choose_closest_candidate(cands, fine, grid, map, hm);
      R.slid_clusters = C.clusters - (C.chosen.empty() ? 0 : C.chosen[0]);
      R.slid_elements = C.elements_changed;
      const ValidityReport fin = check_validity(hm, opt.validity);
      R.validity.invalid_after = fin.invalid_after;
      R.validity.min_scaled_jacobian = fin.min_scaled_jacobian;
      R.validity.invalid_faces = fin.invalid_faces;
    } else {
      hm = std::move(cands[0]);
    }
  }
  R.seconds_validity = seconds_since(t0);
  R.seconds_total = seconds_since(t_all);
  progress("done", 1.0);
  return R;
}

}  // namespace hocurve
