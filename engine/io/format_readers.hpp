// Per-format parsers behind read_mesh_bytes (internal to engine/io; not a public interface).
// Each takes the whole (already inflated) file content and fills a Mesh plus the report's
// warnings and facet count. All of them throw InputError with the file name and a location.
#pragma once
#include "engine/io/read_mesh.hpp"

#include <Eigen/Core>
#include <string>
#include <vector>
#include <string_view>

namespace hocurve::io_detail {

void read_stl_binary(std::string_view bytes, const std::string& name, const ReadOptions& opt, ReadResult& out);
void read_stl_ascii(std::string_view bytes, const std::string& name, const ReadOptions& opt, ReadResult& out);
void read_obj(std::string_view bytes, const std::string& name, ReadResult& out);
void read_ply(std::string_view bytes, const std::string& name, ReadResult& out);
void read_off(std::string_view bytes, const std::string& name, ReadResult& out);
void read_msh(std::string_view bytes, const std::string& name, ReadResult& out);

/// Nodes per element of a Gmsh element type (0 = unknown); binary .msh files need it to step over
/// elements.
int msh_nodes_per_element(int type);

/// Appends the triangles of polygon `poly` (indices into V, which must hold its corners' positions;
/// validated by the caller): a quadrangle is cut along its shorter diagonal, a larger polygon is
/// fan-split around its first corner, fewer than 3 corners add nothing.
void split_polygon(const Eigen::MatrixXd& V, const std::vector<long long>& poly, std::vector<int>& tri);

/// The warning that `polygons` faces of file `name` had more than 3 corners.
std::string polygons_warning(const std::string& name, long long polygons);

/// Throws InputError naming the first vertex with a NaN/Inf coordinate.
void check_finite_vertices(const Mesh& mesh, const std::string& name, bool from_one = false);

}  // namespace hocurve::io_detail
