// Cheap upload checks done on the HTTP thread before a job is queued: the mesh format from the
// first bytes, and the one count that can be checked without parsing (binary STL facet count).
#pragma once
#include <cstdint>
#include <string>

namespace hocurve::server {

struct SniffResult {
  std::string format;     ///< "stl-ascii", "stl-binary", "obj", "ply", "off", "msh", "gzip", or "" (unknown)
  std::string extension;  ///< file extension to keep for the input (".stl", ".obj", ..., ".gz")
  std::string refusal;    ///< non-empty: the upload is certainly not a valid mesh (422), with why
};

/// Looks at `head` (the first bytes of the upload) and its total `size`; `name_hint` is a client
/// file name, used only for gzip (".stl.gz") and as a tie-breaker.
SniffResult sniff_mesh(const std::string& head, std::uint64_t size, const std::string& name_hint);

}  // namespace hocurve::server
