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

/// The faces of an indexed format (OBJ, PLY, OFF) as read, any number of corners each; triangles
/// are made once every vertex position is known (a PLY may list its faces before its vertices, and a
/// quadrangle's cut depends on positions).
class PolygonFaces {
 public:
  /// Adds a corner (a vertex index, already checked) to the face being read.
  void corner(long long v) { corners_.push_back(v); }
  /// Ends the face being read: one with fewer than 3 corners is dropped and counted.
  void end_face();
  /// Fills m.F (m.V must hold every position) and adds the warnings on polygons and small faces.
  void to_triangles(Mesh& m, const std::string& name, ReadReport& report) const;

 private:
  std::vector<long long> corners_;
  std::vector<std::size_t> ends_;  ///< one past each face's last corner
  std::size_t begin_ = 0;          ///< first corner of the face being read
  long long polygons_ = 0, small_ = 0;
};

/// Appends the triangles of polygon `poly` (indices into V, which must hold its corners' positions;
/// validated by the caller): a quadrangle is cut along its shorter diagonal, a larger polygon is
/// fan-split around its first corner, fewer than 3 corners add nothing.
void split_polygon(const Eigen::MatrixXd& V, const std::vector<long long>& poly, std::vector<int>& tri);

/// Throws InputError naming the first vertex with a NaN/Inf coordinate.
void check_finite_vertices(const Mesh& mesh, const std::string& name, bool from_one = false);

}  // namespace hocurve::io_detail
