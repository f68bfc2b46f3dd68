#include "engine/curving/stats_json.hpp"

namespace hocurve {
namespace {

/// {model name: count} of the models present.
nlohmann::json model_counts(const std::vector<SurfaceModel>& models) {
  nlohmann::json j = nlohmann::json::object();
  const std::vector<long long> h = model_histogram(models);
  for (size_t m = 0; m < h.size(); ++m)
    if (h[m]) j[model_name(static_cast<SurfaceModel>(m))] = h[m];
  return j;
}

}  // namespace

nlohmann::json stats_json(const CurveResult& r) {
  using nlohmann::json;
  json j;
  j["method"] = r.method;
  j["order"] = r.mesh.order;
  j["distribution"] = to_string(r.mesh.distribution);
  j["topology"] = {{"vertices", r.vertices}, {"faces", r.faces}, {"edges", r.edges},
                   {"seconds", r.topology_seconds}};
  const Features& F = r.features;
  long long feature_edges = 0;
  for (char c : F.edge_feature) feature_edges += c ? 1 : 0;
  j["features"] = {{"feature_edges", feature_edges},  {"sharp_edges", F.sharp_edges}, {"kink_edges", F.kink_edges}, {"gap_edges", F.gap_edges}, {"junction_edges", F.junction_edges},
                   {"pruned_edges", F.pruned_edges}, {"apex_edges", F.apex_edges}, {"quadric_edges", F.quadric_edges},
                   {"boundary_edges", F.boundary_edges}, {"nonmanifold_edges", F.nonmanifold_edges},
                   {"entity_border_edges", F.entity_border_edges}, {"corners", F.corners}, {"cone_points", F.cone_points},
                   {"curves", F.curves.size()},         {"seconds", r.features_seconds}};
  j["distance"] = {{"max_finite", r.distance.max_finite}, {"seconds", r.distance_seconds}};
  const Uniformity& U = r.uniformity;
  j["uniformity"] = {{"uniform", U.uniform},
                     {"reason", U.reason},
                     {"edge_length", {{"min", U.edge_length.min}, {"mean", U.edge_length.mean},
                                      {"max", U.edge_length.max}, {"cv", U.edge_length.cv},
                                      {"p99_p1", U.edge_length.ratio_p99_p1()}}},
                     {"area_cv", U.area.cv},
                     {"needle_share", U.needle_share},
                     {"seconds", r.uniformity_seconds}};
  j["support"] = {{"used", r.support_used}, {"points", r.support_points}, {"seconds", r.support_seconds}};
  json hist = json::object();
  for (size_t d = 0; d < r.fits.degree_histogram.size(); ++d)
    hist[std::to_string(d)] = r.fits.degree_histogram[d];
  j["fits"] = {{"wedges", r.wedges}, {"band_wedges", r.band_wedges},
               {"degree_histogram", hist},
               {"downgraded", r.fits.downgraded},
               {"with_support", r.fits.with_support}, {"agreeing_fits", r.fits.agreeing_fits}, {"apex_fits", r.fits.apex_fits}, {"exact_fits", r.fits.exact_fits}, {"shared_exact_fits", r.fits.shared_exact_fits}, {"refitted_surfaces", r.fits.refitted_surfaces}, {"elevated_fits", r.fits.elevated_fits},
               {"mean_stencil_points", r.fits.mean_points},
               {"seconds", r.fits.seconds}};
  j["curve_fits"] = {{"fitted", r.curve_fits.fitted}, {"downgraded", r.curve_fits.downgraded},
                     {"straight_edges", r.curve_fits.straight},
                     {"seconds", r.curve_fits.seconds}};
  j["placement"] = {{"curve_edges", r.curve_edges},
                    {"face_exact_fits", r.face_exact_fits},
                    {"crossing_edges", r.crossing_edges},
                    {"smooth_surface", r.smooth_surface},
                    {"long_edges", r.long_edges},
                    {"long_edges_placed", r.long_edges_placed},
                    {"long_faces", r.long_faces},
                    {"planar_patches", r.planar.patches},
                    {"planar_faces", r.planar.faces},
                    {"planar_max_move", r.planar.max_move},
                    {"bounded_edges", r.offset_bound.edges},
                    {"bounded_faces", r.offset_bound.faces},
                    {"bounded_min_scale", r.offset_bound.min_scale},
                    {"seconds", r.placement_seconds}};
  j["models"] = {{"wedges", model_counts(r.wedge_models)}, {"elements", model_counts(r.face_models)}};
  j["untangle"] = {{"targets", r.untangle.targets},
                   {"patches", r.untangle.patches},
                   {"kept", r.untangle.kept},
                   {"cleared", r.untangle.cleared},
                   {"seconds", r.untangle.seconds}};
  const ValidityReport& V = r.validity;
  j["validity"] = {{"checked", V.checked},
                   {"invalid_before", V.invalid_before},
                   {"repaired", V.repaired},
                   {"below_min_jacobian", V.below_floor_before},
                   {"min_jacobian_repaired", V.quality_repaired},
                   {"needles_aligned", V.needles_aligned},
                   {"invalid_after", V.invalid_after},
                   {"degenerate_input", V.degenerate_input},
                   {"min_scaled_jacobian", V.min_scaled_jacobian},
                   {"seconds", r.validity_seconds}};
  j["deviation"] = {{"max", r.deviation.max},
                    {"rms", r.deviation.rms},
                    {"bbox_diagonal", r.deviation.bbox_diagonal},
                    {"max_relative", r.deviation.max_relative},
                    {"rms_relative", r.deviation.rms_relative},
                    {"normal_max", r.deviation.normal_max},
                    {"normal_rms", r.deviation.normal_rms},
                    {"normal_max_relative", r.deviation.normal_max_relative},
                    {"normal_rms_relative", r.deviation.normal_rms_relative}};
  j["total_seconds"] = r.total_seconds;
  return j;
}

}  // namespace hocurve
