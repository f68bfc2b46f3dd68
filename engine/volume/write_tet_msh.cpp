// Streams the sections through a small buffer; numbers by std::to_chars, binary little-endian.
#include "engine/volume/write_tet_msh.hpp"

#include "engine/core/error.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <charconv>
#include <cstring>
#include <map>
#include <initializer_list>

namespace hocurve {

namespace {

class Out {
 public:
  Out(const ByteSink& sink, bool binary) : sink_(sink), binary_(binary) {}
  void flush() {
    sink_(buf_.data(), buf_.size());
    buf_.clear();
  }
  void str(const std::string& s) { put(s.data(), s.size()); }
  // A count or tag: text (after a space unless first on the line) or binary of type B.
  template <class B, class T>
  void num(T v, bool first = false) {
    if (binary_) {
      const B b = static_cast<B>(v);
      put(&b, sizeof b);
      return;
    }
    char tmp[32];
    char* e = tmp;
    if (!first) *e++ = ' ';
    e = std::to_chars(e, tmp + sizeof tmp, v).ptr;
    put(tmp, static_cast<std::size_t>(e - tmp));
  }
  void eol() {
    if (!binary_) put("\n", 1);
  }
  // Closes a section: binary data ends with a newline of its own.
  void end(const std::string& name) { str((binary_ ? "\n$End" : "$End") + name + "\n"); }

 private:
  void put(const void* p, std::size_t n) {
    buf_.append(static_cast<const char*>(p), n);
    if (buf_.size() > (1u << 20)) flush();
  }
  const ByteSink& sink_;
  bool binary_;
  std::string buf_;
};

struct Surface {
  int tag;
  std::vector<int> faces, groups;
};

struct Layout {
  std::vector<Surface> surfaces;
  std::vector<PhysicalGroup> groups;  // dimension 2
};

Layout layout(const TetMesh& tm, const TetMshOptions& opt) {
  Layout l;
  std::map<int, Surface> by_tag;
  for (int f = 0; f < tm.B.rows(); ++f) {
    const int tag = tm.face_entity.size() ? tm.face_entity[f] : 1;
    by_tag.try_emplace(tag, Surface{tag, {}, {}}).first->second.faces.push_back(f);
  }
  l.groups = tm.physicals;
  if (l.groups.empty()) {
    l.groups.push_back({1, opt.boundary_name, {}});
    for (auto& [tag, s] : by_tag) l.groups[0].entities.push_back(tag);
  }
  for (auto& [tag, s] : by_tag) {
    for (const PhysicalGroup& g : l.groups)
      if (std::find(g.entities.begin(), g.entities.end(), tag) != g.entities.end()) s.groups.push_back(g.tag);
    l.surfaces.push_back(std::move(s));
  }
  return l;
}

void bbox(const TetMesh& tm, Out& o) {
  const Eigen::RowVector3d lo = tm.X.colwise().minCoeff(), hi = tm.X.colwise().maxCoeff();
  for (double v : {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]}) o.num<double>(v);
}

void counts(Out& o, std::initializer_list<std::uint64_t> c);

void write_entities(const TetMesh& tm, const Layout& l, Out& o) {
  o.str("$Entities\n");
  counts(o, {0, 0, l.surfaces.size(), 1});
  for (const Surface& s : l.surfaces) {  // the whole mesh's box: cheap and valid
    o.num<std::int32_t>(s.tag, true);
    bbox(tm, o);
    o.num<std::uint64_t>(s.groups.size());
    for (int g : s.groups) o.num<std::int32_t>(g);
    o.num<std::uint64_t>(0);
    o.eol();
  }
  o.num<std::int32_t>(1, true);
  bbox(tm, o);
  o.num<std::uint64_t>(1);
  o.num<std::int32_t>(1);
  o.num<std::uint64_t>(l.surfaces.size());
  for (const Surface& s : l.surfaces) o.num<std::int32_t>(s.tag);
  o.eol();
  o.end("Entities");
}

// A line of counts: "a b c d" in text, size_t each in binary.
void counts(Out& o, std::initializer_list<std::uint64_t> c) {
  bool first = true;
  for (std::uint64_t v : c) o.num<std::uint64_t>(v, first), first = false;
  o.eol();
}

void write_nodes(const TetMesh& tm, bool v41, Out& o) {
  const std::uint64_t n = static_cast<std::uint64_t>(tm.X.rows());
  o.str("$Nodes\n");
  if (v41) {
    counts(o, {1, n, 1, n});
    o.num<std::int32_t>(3, true);
    o.num<std::int32_t>(1);
    o.num<std::int32_t>(0);
    o.num<std::uint64_t>(n);
    o.eol();
    for (std::uint64_t t = 1; t <= n; ++t) o.num<std::uint64_t>(t, true), o.eol();
  } else {
    o.str(std::to_string(n) + "\n");
  }
  for (Eigen::Index i = 0; i < tm.X.rows(); ++i) {
    if (!v41) o.num<std::int32_t>(i + 1, true);
    for (int k = 0; k < 3; ++k) o.num<double>(tm.X(i, k), v41 && k == 0);
    o.eol();
  }
  o.end("Nodes");
}

// One element. 4.1: tag, nodes. 2.2: tag, [type (text only)], 2 tags, nodes.
template <class I>
void element(Out& o, long long tag, const Eigen::MatrixXi& C, int row, bool v41, bool bin, int type, int phys,
             int entity) {
  o.num<I>(tag, true);
  if (!v41) {
    if (!bin) o.num<std::int32_t>(type), o.num<std::int32_t>(2);
    o.num<std::int32_t>(phys);
    o.num<std::int32_t>(entity);
  }
  for (Eigen::Index k = 0; k < C.cols(); ++k) o.num<I>(C(row, k) + 1);
  o.eol();
}

}  // namespace

void write_tet_msh(const TetMesh& tm, const ByteSink& sink, const TetMshOptions& opt) {
  if (!tm.X.allFinite()) throw InputError("TetMesh", "non-finite node coordinates");
  const bool v41 = opt.msh.version == MshOptions::Version::V41, bin = opt.msh.binary;
  const Layout l = layout(tm, opt);
  const int tri = gmsh_triangle_type(tm.order), tet = gmsh_tet_type(tm.order);
  const long long nf = tm.B.rows(), nt = tm.T.rows();
  Out o(sink, bin);
  o.str(std::string("$MeshFormat\n") + (v41 ? "4.1 " : "2.2 ") + (bin ? "1 8\n" : "0 8\n"));
  if (bin) o.num<std::int32_t>(1), o.str("\n");
  o.str("$EndMeshFormat\n$HocurveInfo\nnodes equispaced order " + std::to_string(tm.order) +
        " generator hocurve\n$EndHocurveInfo\n");
  std::string names;
  int named = 1;
  for (const PhysicalGroup& g : l.groups)
    if (!g.name.empty()) names += "2 " + std::to_string(g.tag) + " \"" + g.name + "\"\n", ++named;
  o.str("$PhysicalNames\n" + std::to_string(named) + "\n" + names + "3 1 \"" + opt.volume_name +
        "\"\n$EndPhysicalNames\n");
  if (v41) write_entities(tm, l, o);
  write_nodes(tm, v41, o);
  o.str("$Elements\n");
  const std::uint64_t total = static_cast<std::uint64_t>(nf + nt);
  if (v41) counts(o, {l.surfaces.size() + 1, total, 1, total});
  else o.str(std::to_string(total) + "\n");
  auto block = [&](int dim, int entity, int type, std::size_t count) {
    if (v41) {
      o.num<std::int32_t>(dim, true);
      o.num<std::int32_t>(entity);
      o.num<std::int32_t>(type);
      o.num<std::uint64_t>(count);
      o.eol();
    } else if (bin) {  // 2.2 binary: a header per run of one type
      o.num<std::int32_t>(type, true);
      o.num<std::int32_t>(count);
      o.num<std::int32_t>(2);
    }
  };
  for (const Surface& s : l.surfaces) {
    block(2, s.tag, tri, s.faces.size());
    const int phys = s.groups.empty() ? 0 : s.groups.front();
    for (int f : s.faces)
      v41 ? element<std::uint64_t>(o, f + 1, tm.B, f, true, bin, tri, phys, s.tag)
          : element<std::int32_t>(o, f + 1, tm.B, f, false, bin, tri, phys, s.tag);
  }
  block(3, 1, tet, static_cast<std::size_t>(nt));
  for (int t = 0; t < nt; ++t)
    v41 ? element<std::uint64_t>(o, nf + t + 1, tm.T, t, true, bin, tet, 1, 1)
        : element<std::int32_t>(o, nf + t + 1, tm.T, t, false, bin, tet, 1, 1);
  o.end("Elements");
  o.flush();
}

void write_tet_msh_file(const TetMesh& tm, const std::string& path, const TetMshOptions& opt) {
  write_file_atomically(path, [&](const ByteSink& sink) { write_tet_msh(tm, sink, opt); });
}

}  // namespace hocurve
