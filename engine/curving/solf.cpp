#include "engine/curving/solf.hpp"

#include "engine/core/error.hpp"
#include "engine/core/stopwatch.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/band_fit.hpp"
#include "engine/curving/place_nodes.hpp"
#include "engine/curving/planar_patches.hpp"
#include "engine/curving/share_exact_fits.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/curving/untangle.hpp"

#include <chrono>
#include <cmath>
#include <limits>

namespace hocurve {

namespace {

/// Per face, the exact surface that placed its nodes (null where the placement reverted it).
std::vector<const LocalFit*> face_fits_placed(const PlacementResult& P, std::vector<const LocalFit*> fits) {
  for (size_t f = 0; f < fits.size(); ++f)
    if (f >= P.face_on_exact.size() || !P.face_on_exact[f]) fits[f] = nullptr;
  return fits;
}

/// Faces whose nodes the untangling or the repair moved (checksums before / after) are Repaired.
void mark_repaired(const std::vector<double>& before, const std::vector<double>& after,
                   std::vector<SurfaceModel>& models) {
  models.resize(after.size(), SurfaceModel::Straight);
  for (size_t f = 0; f < after.size() && f < before.size(); ++f)
    if (after[f] != before[f]) models[f] = SurfaceModel::Repaired;
}

}  // namespace

Deviation measure_deviation(const Mesh& mesh, const HighOrderMesh& hm) {
  Deviation D;
  if (mesh.num_vertices() > 0)
    D.bbox_diagonal = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
  const int p = hm.order;
  if (p <= 1) return D;
  const Eigen::VectorXd line = line_reference_nodes(p, hm.distribution);
  const Eigen::MatrixXd tri = triangle_reference_nodes(p, hm.distribution);
  const int npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  // Unit normals of the straight triangles (zero for a degenerate one: its offsets count whole),
  // and up to two per edge.
  const int nf = hm.num_faces();
  Eigen::MatrixXd normal(nf, 3);
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d n = face_normal(mesh, f);
    normal.row(f) = n.norm() > 0 ? Eigen::RowVector3d(n.normalized().transpose()) : Eigen::RowVector3d::Zero();
  }
  Eigen::MatrixXi edge_face = Eigen::MatrixXi::Constant(hm.E.rows(), 2, -1);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      const int e = hm.FE(f, j);
      edge_face(e, edge_face(e, 0) < 0 ? 0 : 1) = f;
    }
  double sum2 = 0, normal_sum2 = 0;
  long long count = 0;
  auto along = [&](const Eigen::Vector3d& d, int f) {
    return f < 0 ? std::numeric_limits<double>::infinity()
                 : normal.row(f).squaredNorm() > 0 ? std::abs(normal.row(f).dot(d)) : d.norm();
  };
  auto add = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, int f, int g) {
    const Eigen::Vector3d offset = a - b;
    const double d = offset.norm(), dn = std::min({d, along(offset, f), along(offset, g)});
    D.max = std::max(D.max, d);
    D.normal_max = std::max(D.normal_max, dn);
    sum2 += d * d;
    normal_sum2 += dn * dn;
    ++count;
  };
  for (Eigen::Index e = 0; e < hm.E.rows(); ++e)
    for (int k = 1; k < p; ++k) {
      const double t = line[k];
      const Eigen::Vector3d x = (1 - t) * mesh.V.row(hm.E(e, 0)) + t * mesh.V.row(hm.E(e, 1));
      add(hm.edge_nodes.row(e * npe + k - 1).transpose(), x, edge_face(e, 0), edge_face(e, 1));
    }
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < npf; ++k) {
      const double u = tri(3 * p + k, 0), v = tri(3 * p + k, 1);
      const Eigen::Vector3d x = (1 - u - v) * mesh.V.row(mesh.F(f, 0)) + u * mesh.V.row(mesh.F(f, 1)) +
                                v * mesh.V.row(mesh.F(f, 2));
      add(hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k).transpose(), x, f, -1);
    }
  D.rms = count ? std::sqrt(sum2 / count) : 0;
  D.normal_rms = count ? std::sqrt(normal_sum2 / count) : 0;
  if (D.bbox_diagonal > 0) {
    D.max_relative = D.max / D.bbox_diagonal, D.rms_relative = D.rms / D.bbox_diagonal;
    D.normal_max_relative = D.normal_max / D.bbox_diagonal, D.normal_rms_relative = D.normal_rms / D.bbox_diagonal;
  }
  return D;
}

CurveResult curve_mesh(const Mesh& mesh, const CurveOptions& opt) {
  if (opt.order < 1 || opt.order > 6)
    throw UsageError("order " + std::to_string(opt.order) + " is outside 1..6");
  if (mesh.num_faces() == 0 || mesh.num_vertices() < 3) throw InputError("", "the mesh has no triangles");
  const auto t_all = Clock::now();
  const int p = opt.order;
  auto progress = [&](const char* stage, double f) {
    if (opt.progress) opt.progress(stage, f);
  };
  CurveResult R;
  std::vector<ElementValidity> floor_checks;  // the untangling's element checks, for the repair
  std::vector<double> placed_before_untangle;   // node checksums as placed: what the repairs moved
  R.method = opt.method == CurveOptions::Method::Solf ? "solf" : "linear";
  R.vertices = mesh.num_vertices();
  R.faces = mesh.num_faces();

  progress("topology", 0.0);
  auto t0 = Clock::now();
  const Topology T = build_topology(mesh.F, mesh.num_vertices());
  R.edges = T.num_edges();
  R.topology_seconds = seconds_since(t0);

  if (opt.method == CurveOptions::Method::Linear) {
    progress("placement", 0.5);
    t0 = Clock::now();
    R.mesh = make_straight_high_order(mesh, T, p, opt.distribution);
    R.placement_seconds = seconds_since(t0);
  } else {
    progress("features", 0.05);
    t0 = Clock::now();
    // What "on a quadric to rounding" means depends on how the input stored its coordinates.
    const double rounding = coordinate_rounding(mesh);
    FeatureOptions feature_opt = opt.features;
    FitOptions fit_opt = opt.fit;
    if (feature_opt.quadric.rounding == 0) feature_opt.quadric.rounding = rounding;
    if (fit_opt.exact.rounding == 0) fit_opt.exact.rounding = rounding;
    R.features = detect_features(mesh, T, feature_opt);
    R.features_seconds = seconds_since(t0);

    progress("distance", 0.1);
    t0 = Clock::now();
    R.distance = feature_distance(mesh, T, R.features, opt.distance);
    R.distance_seconds = seconds_since(t0);

    progress("uniformity", 0.15);
    t0 = Clock::now();
    R.uniformity = check_uniformity(mesh, T, opt.uniformity);
    R.uniformity_seconds = seconds_since(t0);

    R.support_used = opt.use_support == Tristate::On ||
                     (opt.use_support == Tristate::Auto && !R.uniformity.uniform);
    SupportPoints support;
    if (R.support_used && p >= 2) {
      progress("support", 0.2);
      t0 = Clock::now();
      support = sample_support(mesh, opt.support);
      R.support_points = support.P.rows();
      R.support_seconds = seconds_since(t0);
    }

    progress("fits", 0.25);
    const Wedges W = build_wedges(mesh, T, R.features.edge_feature, R.features.vertex_cone);
    R.wedges = W.num_wedges();
    if (p >= 2) {
      const int d = fit_degree(p, fit_opt);
      R.fits = fit_wedges(mesh, T, W, d, R.support_used ? &support : nullptr, fit_opt);
      R.band_wedges = refit_band_wedges(mesh, T, W, R.features, d, fit_opt, R.fits.fits);
      progress("curve fits", 0.6);
      R.curve_fits = fit_feature_curves(mesh, T, R.features, d, fit_opt);
    } else {
      R.fits.fits.resize(W.num_wedges());
      R.fits.degree_histogram.assign(2, 0);
    }

    progress("placement", 0.7);
    const std::vector<int> planar = planar_patch_faces(mesh, T, opt.planar, &R.features.edge_feature);
    LongEdgeOptions long_opt = opt.long_edges;
    R.smooth_surface = smooth_surface(R.features, T, planar, long_opt);
    if (R.smooth_surface) long_opt.ratio = 0;
    const std::vector<const LocalFit*> face_fits = face_exact_fits(mesh, T, W, R.fits.fits, fit_opt.exact);
    const LongEdgeResult long_edge =
        p >= 2 ? long_edges(mesh, T, W, R.fits.fits, long_opt, &face_fits) : LongEdgeResult{};
    PlacementResult P = place_nodes(mesh, T, W, R.fits.fits, &R.features,
                                    R.curve_fits.fits.empty() ? nullptr : &R.curve_fits, p,
                                    opt.distribution, p >= 2 ? &long_edge : nullptr, &planar, &face_fits);
    R.mesh = std::move(P.mesh);
    R.offset_bound = bound_offsets(mesh, T, W, R.fits.fits, &face_fits, R.mesh, opt.offset_bound);
    R.long_edges = long_edge.edges;
    R.long_edges_placed = P.long_edges;
    R.long_faces = long_edge.faces;
    R.planar = flatten_planar_patches(mesh, T, R.mesh, planar);
    if (p >= 2) {
      R.wedge_models = wedge_models(mesh, T, W, R.features, R.fits.fits);
      R.face_models = placement_models(mesh, W, R.wedge_models, face_fits_placed(P, face_fits), long_edge.face,
                                       planar, R.offset_bound.face);
    }
    R.curve_edges = P.curve_edges;
    R.face_exact_fits = P.face_exact_fits;
    R.placement_seconds = P.seconds;
    R.crossing_edges = P.crossing_edges;
    if (opt.repair && p >= 2) {
      // Edges on two exact surfaces' crossing stay where they are, as feature edges do.
      std::vector<char> fixed = R.features.edge_feature;
      for (size_t e = 0; e < fixed.size() && e < P.crossing.size(); ++e) fixed[e] = fixed[e] || P.crossing[e];
      const SurfaceOfFaces surface{&mesh, &W, &R.fits.fits, &planar, &face_fits, &long_edge};
      placed_before_untangle = node_checksums(R.mesh);
      R.untangle = untangle_in_surface(T, fixed, surface, opt.validity, R.mesh, opt.untangle, &floor_checks);
    }
  }

  progress("validity", 0.85);
  t0 = Clock::now();
  const std::vector<double> placed = node_checksums(R.mesh);
  // The untangling checked at max(min_scaled_jacobian, quality_floor): the repair's floor pass,
  // which runs only when the floor is the higher.
  R.validity = opt.repair ? repair_validity(R.mesh, opt.validity, std::move(floor_checks))
                          : check_validity(R.mesh, opt.validity);
  R.validity_seconds = seconds_since(t0);
  mark_repaired(placed_before_untangle.empty() ? placed : placed_before_untangle, node_checksums(R.mesh),
                R.face_models);
  R.deviation = measure_deviation(mesh, R.mesh);
  R.total_seconds = seconds_since(t_all);
  progress("done", 1.0);
  return R;
}

}  // namespace hocurve
