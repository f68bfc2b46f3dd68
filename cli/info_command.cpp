// hocurve info: counts, bounding box, edge-length statistics and topology problems.
#include "cli/command_options.hpp"
#include "cli/commands.hpp"
#include "cli/common.hpp"

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/uniformity.hpp"

#include <iostream>

namespace hocurve::cli {

namespace {
nlohmann::json spread_json(const Spread& s) {
  return {{"min", s.min}, {"mean", s.mean}, {"max", s.max}, {"cv", s.cv},
          {"p1", s.p1},   {"p99", s.p99},   {"p99_over_p1", s.ratio_p99_p1()}};
}
}  // namespace

int run_info(int argc, char** argv) {
  Args a = parse_command_line(argc, argv, kInfo);
  if (a.has("help")) {
    std::cout << command_help("usage: hocurve info INPUT [options]\n"
                              "Reads and validates a mesh and prints counts, bounding box, edge-length\n"
                              "statistics, features and topology problems.\n",
                              kInfo);
    return 0;
  }
  if (a.positional.size() != 1) throw UsageError("info needs exactly one INPUT file (see --help)");
  OptionSettings o;
  apply_options(a, kInfo, o);
  const std::string input = a.positional[0];
  LoadedInput in = load_input(input, Progress{}, o.read);
  const Mesh& m = in.mesh;
  Topology T = build_topology(m.F, m.num_vertices());
  Features feat = detect_features(m, T, o.features);
  Uniformity uni = check_uniformity(m, T);
  Eigen::RowVector3d lo = m.V.colwise().minCoeff(), hi = m.V.colwise().maxCoeff();
  const long long chi = m.num_vertices() - T.num_edges() + m.num_faces();

  nlohmann::json j = input_json(input, in);
  j["edges"] = T.num_edges();
  j["euler_characteristic"] = chi;
  j["bounding_box"] = {{"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}},
                       {"diagonal", (hi - lo).norm()}};
  j["edge_length"] = spread_json(uni.edge_length);
  j["area"] = spread_json(uni.area);
  j["needle_share"] = uni.needle_share;
  j["uniform"] = uni.uniform;
  j["uniformity_reason"] = uni.reason;
  j["features"] = {{"sharp_edges", feat.sharp_edges},     {"boundary_edges", feat.boundary_edges},
                   {"nonmanifold_edges", feat.nonmanifold_edges},
                   {"entity_border_edges", feat.entity_border_edges},
                   {"curves", feat.curves.size()},        {"corners", feat.corners}, {"cone_points", feat.cone_points}};
  if (o.json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << input << " (" << in.read.format << (in.read.gzip ? ", gzip" : "") << ")\n"
            << "  vertices " << m.num_vertices() << ", faces " << m.num_faces() << ", edges " << T.num_edges()
            << ", components " << in.validation.components << ", Euler characteristic " << chi << "\n"
            << "  bounding box [" << lo[0] << ", " << lo[1] << ", " << lo[2] << "] - [" << hi[0] << ", "
            << hi[1] << ", " << hi[2] << "], diagonal " << (hi - lo).norm() << "\n"
            << "  edge length min " << uni.edge_length.min << ", mean " << uni.edge_length.mean << ", max "
            << uni.edge_length.max << ", cv " << uni.edge_length.cv << ", p99/p1 "
            << uni.edge_length.ratio_p99_p1() << "\n"
            << "  needles " << 100.0 * uni.needle_share << "%, "
            << (uni.uniform ? "uniform" : "non-uniform: " + uni.reason) << "\n"
            << "  features: " << feat.sharp_edges << " sharp, " << feat.boundary_edges << " boundary, "
            << feat.nonmanifold_edges << " non-manifold, " << feat.entity_border_edges
            << " entity-border edges; " << feat.curves.size() << " curves, " << feat.corners << " corners, " << feat.cone_points << " cone points\n"
            << "  topology: " << in.validation.boundary_edges << " boundary edges, "
            << in.validation.nonmanifold_edges << " non-manifold edges, " << in.validation.nonmanifold_vertices
            << " non-manifold vertices, " << in.validation.flipped_faces << " faces re-oriented, "
            << in.validation.duplicate_faces << " duplicate and " << in.validation.degenerate_faces
            << " degenerate faces removed, " << in.validation.zero_area_faces << " zero-area faces\n";
  for (const auto& w : j["warnings"]) std::cout << "  warning: " << w.get<std::string>() << "\n";
  return 0;
}

}  // namespace hocurve::cli
