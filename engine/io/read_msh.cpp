// Gmsh MSH 2.2 and 4.1, ASCII and binary (little-endian). Keeps triangles (type 2; the corner
// nodes of higher-order triangles), quadrangles split in two triangles, their surface entity tags
// and the dimension-2 physical groups.
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"

#include <algorithm>
#include <charconv>
#include <cstring>
#include <map>
#include <unordered_map>

namespace hocurve::io_detail {

int msh_nodes_per_element(int type) {
  // Gmsh 4.8 getElementProperties' node counts for types 0-137 (0: unknown or variable, as polygons).
  static constexpr int table[] = {
      0, 2, 3, 4, 4, 8, 6, 5, 3, 6,  // 0-9
      9, 10, 27, 18, 14, 1, 8, 20, 15, 13,  // 10-19
      9, 10, 12, 15, 15, 21, 4, 5, 6, 20,  // 20-29
      35, 56, 22, 28, 0, 0, 16, 25, 36, 12,  // 30-39
      16, 20, 28, 36, 45, 55, 66, 49, 64, 81,  // 40-49
      100, 121, 18, 21, 24, 27, 30, 24, 28, 32,  // 50-59
      36, 40, 7, 8, 9, 10, 11, 0, 0, 0,  // 60-69
      0, 84, 120, 165, 220, 286, 0, 0, 0, 34,  // 70-79
      40, 46, 52, 58, 1, 1, 1, 1, 1, 1,  // 80-89
      0, 0, 64, 125, 216, 343, 512, 729, 1000, 32,  // 90-99
      44, 56, 68, 80, 92, 104, 0, 0, 0, 0,  // 100-109
      0, 0, 0, 0, 0, 0, 0, 0, 30, 55,  // 110-119
      91, 140, 204, 285, 385, 21, 29, 37, 45, 53,  // 120-129
      61, 69, 1, 0, 0, 0, 0, 16};  // 130-137
  return type >= 0 && type < static_cast<int>(std::size(table)) ? table[type] : 0;
}

namespace {

/// Triangle element types: 2 (linear) and the high-order ones, whose first 3 nodes are corners.
bool is_triangle(int type) {
  return type == 2 || type == 9 || (type >= 20 && type <= 25) || (type >= 42 && type <= 46) ||
         (type >= 52 && type <= 56);
}

/// Quadrangle element types: 3 (linear) and the high-order ones, whose first 4 nodes are corners.
bool is_quad(int type) {
  return type == 3 || type == 10 || type == 16 || (type >= 36 && type <= 41) || (type >= 47 && type <= 51) ||
         (type >= 57 && type <= 61);
}

class Cursor {
 public:
  Cursor(std::string_view s, const std::string& name) : s_(s), name_(name) {}

  bool binary = false;
  int size_t_bytes = 8;

  std::string where() const {
    return binary ? name_ + ": byte " + std::to_string(p_) : name_ + ": line " + std::to_string(line_);
  }
  [[noreturn]] void fail(const std::string& why) const { throw InputError(where(), why); }
  bool at_end() {
    skip_space();
    return p_ >= s_.size();
  }
  void skip_space() {
    while (p_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[p_]))) {
      if (s_[p_] == '\n') ++line_;
      ++p_;
    }
  }
  /// Next line without its end-of-line and surrounding blanks.
  std::string_view line() {
    if (p_ >= s_.size()) fail("unexpected end of file");
    std::size_t e = s_.find('\n', p_);
    if (e == std::string_view::npos) e = s_.size();
    std::string_view l = s_.substr(p_, e - p_);
    p_ = std::min(e + 1, s_.size());
    ++line_;
    while (!l.empty() && std::isspace(static_cast<unsigned char>(l.back()))) l.remove_suffix(1);
    while (!l.empty() && std::isspace(static_cast<unsigned char>(l.front()))) l.remove_prefix(1);
    return l;
  }
  std::string_view token() {
    skip_space();
    const std::size_t b = p_;
    while (p_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[p_]))) ++p_;
    if (b == p_) fail("unexpected end of file");
    return s_.substr(b, p_ - b);
  }
  long long integer(const char* what) {
    const std::string_view t = token();
    long long v = 0;
    auto [q, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    if (ec != std::errc() || q != t.data() + t.size())
      fail(std::string("expected ") + what + ", found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  long long count(const char* what) {
    const long long v = integer(what);
    if (v < 0) fail(std::string("negative ") + what);
    return v;
  }
  double number() {
    const std::string_view t = token();
    double v = 0;
    const char* b = t.data() + (t[0] == '+' ? 1 : 0);
    auto [q, ec] = std::from_chars(b, t.data() + t.size(), v);
    if (ec == std::errc::result_out_of_range) return std::strtod(std::string(t).c_str(), nullptr);
    if (ec != std::errc() || q != t.data() + t.size())
      fail("expected a number, found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  template <class T>
  T bin() {
    if (p_ + sizeof(T) > s_.size()) fail("unexpected end of binary data");
    T v;
    std::memcpy(&v, s_.data() + p_, sizeof(T));
    p_ += sizeof(T);
    return v;
  }
  unsigned long long bin_size() {
    return size_t_bytes == 8 ? bin<std::uint64_t>() : bin<std::uint32_t>();
  }
  /// Refuses a count whose items (each at least `bytes` long) cannot fit in the rest of the file.
  void check_fits(unsigned long long n, unsigned long long bytes, const char* what) const {
    if (bytes && n > (s_.size() - p_) / bytes + 1)
      fail(std::string(what) + " count " + std::to_string(n) + " exceeds what the file can hold (" +
           std::to_string(s_.size() - p_) + " bytes left)");
  }
  /// Consumes the rest of the current line (blanks only) and its newline: binary data follows.
  void end_line() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\t' || s_[p_] == '\r')) ++p_;
    if (p_ >= s_.size() || s_[p_] != '\n') fail("expected the end of the line before binary data");
    ++p_;
  }
  /// Expects the closing "$EndName" line (after optional white space).
  void expect_end(std::string_view section) {
    skip_space();
    const std::string_view l = line();
    if (l.substr(0, 4 + section.size()) != std::string("$End") + std::string(section))
      fail("expected $End" + std::string(section) + ", found '" + std::string(l.substr(0, 40)) + "'");
  }
  /// Skips an unknown section up to its "$EndName" line.
  void skip_section(std::string_view section) {
    const std::string end = "$End" + std::string(section);
    const std::size_t e = s_.find(end, p_);
    if (e == std::string_view::npos) fail("section $" + std::string(section) + " has no " + end);
    if (!binary) line_ += std::count(s_.begin() + p_, s_.begin() + e, '\n');
    p_ = e;
    line();
  }

 private:
  std::string_view s_;
  const std::string& name_;
  std::size_t p_ = 0;
  long long line_ = 1;
};

struct MshData {
  int major = 0;
  std::map<int, std::string> names2;              // dimension-2 physical names by tag
  std::map<int, std::vector<int>> surface_phys;   // 4.1: surface entity -> physical tags
  std::vector<std::uint64_t> node_tags;
  std::vector<double> xyz;
  std::vector<std::uint64_t> tri;                 // 3 node tags per triangle
  std::vector<int> tri_entity, tri_phys;
  std::vector<std::uint64_t> quad;                // 4 node tags per quadrangle (split when assembled)
  std::vector<int> quad_entity, quad_phys;
  std::map<int, long long> skipped_types, high_order_types, quad_types;
};

void read_physical_names(Cursor& c, MshData& d) {
  const bool was_binary = c.binary;
  c.binary = false;  // this section is ASCII in every variant
  const long long n = c.count("the number of physical names");
  for (long long i = 0; i < n; ++i) {
    const int dim = static_cast<int>(c.integer("a physical dimension"));
    const int tag = static_cast<int>(c.integer("a physical tag"));
    std::string_view rest = c.line();
    std::string name(rest);
    if (const auto q1 = rest.find('"'); q1 != std::string_view::npos) {
      const auto q2 = rest.find('"', q1 + 1);
      name = std::string(rest.substr(q1 + 1, q2 == std::string_view::npos ? std::string_view::npos : q2 - q1 - 1));
    }
    if (dim == 2) d.names2[tag] = name;
  }
  c.expect_end("PhysicalNames");
  c.binary = was_binary;
}

void read_entities4(Cursor& c, MshData& d) {
  long long n[4];
  for (auto& k : n) k = c.binary ? static_cast<long long>(c.bin_size()) : c.count("an entity count");
  for (int dim = 0; dim < 4; ++dim) {
    c.check_fits(static_cast<unsigned long long>(n[dim]), c.binary ? 28 : 8, "entity");
    for (long long i = 0; i < n[dim]; ++i) {
      const int tag = c.binary ? c.bin<int>() : static_cast<int>(c.integer("an entity tag"));
      for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) c.binary ? (void)c.bin<double>() : (void)c.number();
      const long long np = c.binary ? static_cast<long long>(c.bin_size()) : c.count("a physical count");
      c.check_fits(static_cast<unsigned long long>(np), c.binary ? 4 : 2, "physical tag");
      std::vector<int> phys;
      for (long long k = 0; k < np; ++k)
        phys.push_back(c.binary ? c.bin<int>() : static_cast<int>(c.integer("a physical tag")));
      if (dim == 2) d.surface_phys[tag] = phys;
      if (dim > 0) {
        const long long nb = c.binary ? static_cast<long long>(c.bin_size()) : c.count("a boundary count");
        c.check_fits(static_cast<unsigned long long>(nb), c.binary ? 4 : 2, "boundary entity");
        for (long long k = 0; k < nb; ++k) c.binary ? (void)c.bin<int>() : (void)c.integer("a boundary tag");
      }
    }
  }
  c.expect_end("Entities");
}

void read_nodes2(Cursor& c, MshData& d) {
  const bool was_binary = c.binary;
  c.binary = false;
  const long long n = c.count("the number of nodes");
  c.binary = was_binary;
  if (c.binary) c.end_line();
  c.check_fits(static_cast<unsigned long long>(n), c.binary ? 28 : 8, "node");
  d.node_tags.reserve(d.node_tags.size() + n);
  for (long long i = 0; i < n; ++i) {
    if (c.binary) {
      d.node_tags.push_back(static_cast<std::uint64_t>(c.bin<int>()));
      for (int k = 0; k < 3; ++k) d.xyz.push_back(c.bin<double>());
    } else {
      const long long tag = c.integer("a node tag");
      if (tag < 0) c.fail("negative node tag");
      d.node_tags.push_back(static_cast<std::uint64_t>(tag));
      for (int k = 0; k < 3; ++k) d.xyz.push_back(c.number());
    }
  }
  c.expect_end("Nodes");
}

void read_nodes4(Cursor& c, MshData& d) {
  const auto rd = [&](const char* what) -> unsigned long long {
    return c.binary ? c.bin_size() : static_cast<unsigned long long>(c.count(what));
  };
  const unsigned long long blocks = rd("the number of node blocks");
  const unsigned long long total = rd("the number of nodes");
  rd("the minimum node tag");
  rd("the maximum node tag");
  // Binary sizes with the file's size_t (4 or 8 bytes): a node is a tag and 3 doubles.
  const unsigned long long st = static_cast<unsigned long long>(c.size_t_bytes);
  c.check_fits(total, c.binary ? st + 24 : 8, "node");
  c.check_fits(blocks, c.binary ? 12 + st : 8, "node block");
  d.node_tags.reserve(d.node_tags.size() + total);
  d.xyz.reserve(d.xyz.size() + 3 * total);
  for (unsigned long long b = 0; b < blocks; ++b) {
    const int dim = c.binary ? c.bin<int>() : static_cast<int>(c.integer("an entity dimension"));
    c.binary ? (void)c.bin<int>() : (void)c.integer("an entity tag");
    const int param = c.binary ? c.bin<int>() : static_cast<int>(c.integer("the parametric flag"));
    const unsigned long long n = rd("a block's node count");
    c.check_fits(n, c.binary ? st + 24 : 8, "node");
    const int extra = param ? std::clamp(dim, 0, 3) : 0;
    const std::size_t first = d.node_tags.size();
    for (unsigned long long i = 0; i < n; ++i) d.node_tags.push_back(rd("a node tag"));
    if (d.node_tags.size() - first != n) c.fail("node block count mismatch");
    for (unsigned long long i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) d.xyz.push_back(c.binary ? c.bin<double>() : c.number());
      for (int k = 0; k < extra; ++k) c.binary ? (void)c.bin<double>() : (void)c.number();
    }
  }
  c.expect_end("Nodes");
}

/// Non-negative integers of one line.
std::vector<std::uint64_t> parse_tags(const Cursor& c, std::string_view rest) {
  std::vector<std::uint64_t> out;
  for (std::size_t p = 0; p < rest.size();) {
    while (p < rest.size() && std::isspace(static_cast<unsigned char>(rest[p]))) ++p;
    if (p >= rest.size()) break;
    long long v = 0;
    auto [q, ec] = std::from_chars(rest.data() + p, rest.data() + rest.size(), v);
    if (ec != std::errc() || v < 0 || (q < rest.data() + rest.size() && !std::isspace(static_cast<unsigned char>(*q))))
      c.fail("bad node tag in '" + std::string(rest.substr(0, 60)) + "'");
    out.push_back(static_cast<std::uint64_t>(v));
    p = q - rest.data();
  }
  return out;
}

bool is_face(int type) { return is_triangle(type) || is_quad(type); }

/// Keeps a triangle's or a quadrangle's corner tags (the first 3 or 4 nodes in Gmsh's order).
void add_face(MshData& d, int type, const std::uint64_t* nodes, int entity, int phys) {
  if (is_quad(type)) {
    d.quad.insert(d.quad.end(), nodes, nodes + 4);
    d.quad_entity.push_back(entity);
    d.quad_phys.push_back(phys);
    ++d.quad_types[type];
    return;
  }
  d.tri.insert(d.tri.end(), nodes, nodes + 3);
  d.tri_entity.push_back(entity);
  d.tri_phys.push_back(phys);
  if (type != 2) ++d.high_order_types[type];
}

void read_elements2(Cursor& c, MshData& d) {
  const bool was_binary = c.binary;
  c.binary = false;
  const long long n = c.count("the number of elements");
  c.binary = was_binary;
  if (c.binary) c.end_line();
  c.check_fits(static_cast<unsigned long long>(n), c.binary ? 12 : 8, "element");
  std::vector<std::uint64_t> nodes;
  if (!c.binary) {
    for (long long i = 0; i < n; ++i) {
      c.integer("an element tag");
      const int type = static_cast<int>(c.integer("an element type"));
      const long long ntags = c.count("a tag count");
      if (ntags > 100) c.fail("element " + std::to_string(i) + ": implausible tag count " + std::to_string(ntags));
      std::vector<long long> tags(ntags);
      for (auto& t : tags) t = c.integer("an element tag value");
      // The node list runs to the end of the line.
      nodes = parse_tags(c, c.line());
      if (!is_face(type)) { ++d.skipped_types[type]; continue; }
      const int want = msh_nodes_per_element(type);
      if (static_cast<int>(nodes.size()) != want)
        throw InputError(c.where(), "element " + std::to_string(i) + " (type " + std::to_string(type) + ") has " +
                                        std::to_string(nodes.size()) + " nodes, expected " + std::to_string(want));
      const int phys = ntags >= 1 ? static_cast<int>(tags[0]) : 0;
      const int ent = ntags >= 2 ? static_cast<int>(tags[1]) : 1;
      add_face(d, type, nodes.data(), ent, phys);
    }
  } else {
    long long i = 0;
    while (i < n) {
      const int type = c.bin<int>();
      const int follow = c.bin<int>();
      const int ntags = c.bin<int>();
      const int nn = msh_nodes_per_element(type);
      if (nn == 0) c.fail("element type " + std::to_string(type) + " is not supported in binary msh");
      if (follow < 0 || ntags < 0 || ntags > 100 || follow > n - i) c.fail("bad element block header");
      for (int k = 0; k < follow; ++k, ++i) {
        c.bin<int>();
        std::vector<int> tags(ntags);
        for (auto& t : tags) t = c.bin<int>();
        nodes.resize(nn);
        for (auto& v : nodes) {
          const int t = c.bin<int>();
          if (t < 0) c.fail("negative node tag");
          v = static_cast<std::uint64_t>(t);
        }
        if (!is_face(type)) { ++d.skipped_types[type]; continue; }
        add_face(d, type, nodes.data(), ntags >= 2 ? tags[1] : 1, ntags >= 1 ? tags[0] : 0);
      }
    }
  }
  c.expect_end("Elements");
}

void read_elements4(Cursor& c, MshData& d) {
  const auto rd = [&](const char* what) -> unsigned long long {
    return c.binary ? c.bin_size() : static_cast<unsigned long long>(c.count(what));
  };
  const unsigned long long blocks = rd("the number of element blocks");
  const unsigned long long total = rd("the number of elements");
  rd("the minimum element tag");
  rd("the maximum element tag");
  const unsigned long long st = static_cast<unsigned long long>(c.size_t_bytes);
  c.check_fits(total, c.binary ? 2 * st : 4, "element");
  c.check_fits(blocks, c.binary ? 12 + st : 8, "element block");
  std::vector<std::uint64_t> nodes;
  for (unsigned long long b = 0; b < blocks; ++b) {
    c.binary ? (void)c.bin<int>() : (void)c.integer("an entity dimension");
    const int ent = c.binary ? c.bin<int>() : static_cast<int>(c.integer("an entity tag"));
    const int type = c.binary ? c.bin<int>() : static_cast<int>(c.integer("an element type"));
    const unsigned long long n = rd("a block's element count");
    const int nn = msh_nodes_per_element(type);
    c.check_fits(n, c.binary ? st * (1 + std::max(nn, 1)) : 4, "element");
    if (nn == 0 && c.binary) c.fail("element type " + std::to_string(type) + " is not supported in binary msh");
    for (unsigned long long i = 0; i < n; ++i) {
      if (!is_face(type)) {
        if (c.binary) for (int k = 0; k <= nn; ++k) c.bin_size();
        else { c.integer("an element tag"); c.line(); }
        ++d.skipped_types[type];
        continue;
      }
      if (c.binary) {
        c.bin_size();
        nodes.resize(nn);
        for (auto& v : nodes) v = c.bin_size();
      } else {
        c.skip_space();
        nodes = parse_tags(c, c.line());
        if (static_cast<int>(nodes.size()) != nn + 1)
          c.fail("element of type " + std::to_string(type) + " lists " + std::to_string(nodes.size()) +
                 " numbers, expected its tag and " + std::to_string(nn) + " nodes");
        nodes.erase(nodes.begin());
      }
      add_face(d, type, nodes.data(), ent, 0);
    }
  }
  c.expect_end("Elements");
}

}  // namespace

void read_msh(std::string_view b, const std::string& name, ReadResult& out) {
  Cursor c(b, name);
  MshData d;
  c.skip_space();
  if (c.line() != "$MeshFormat") c.fail("expected $MeshFormat");
  {
    const std::string_view hdr = c.line();
    double version = 0;
    int file_type = 0, data_size = 8;
    if (std::sscanf(std::string(hdr).c_str(), "%lf %d %d", &version, &file_type, &data_size) != 3)
      c.fail("bad $MeshFormat line '" + std::string(hdr.substr(0, 40)) + "'");
    if (version >= 2 && version < 3) d.major = 2;
    else if (version >= 4.1 - 1e-9 && version < 5) d.major = 4;
    else c.fail("MSH version " + std::string(hdr.substr(0, hdr.find(' '))) + " is not supported (use 2.2 or 4.1)");
    if (data_size != 4 && data_size != 8) c.fail("unsupported data size " + std::to_string(data_size));
    c.size_t_bytes = data_size;
    if (file_type == 1) {
      c.binary = true;
      const int one = c.bin<int>();
      if (one != 1) c.fail("big-endian binary .msh is not supported");
    }
    c.expect_end("MeshFormat");
  }
  out.report.format = d.major == 2 ? "msh2" : "msh4";
  bool saw_nodes = false, saw_elements = false;
  while (!c.at_end()) {
    const std::string_view l = c.line();
    if (l.empty() || l[0] != '$') c.fail("expected a section start ($Name), found '" + std::string(l.substr(0, 40)) + "'");
    const std::string_view sec = l.substr(1);
    if (sec == "PhysicalNames") read_physical_names(c, d);
    else if (sec == "Entities" && d.major == 4) read_entities4(c, d);
    else if (sec == "Nodes" || sec == "NOD") {
      if (d.major == 2) read_nodes2(c, d); else read_nodes4(c, d);
      saw_nodes = true;
    } else if (sec == "Elements" || sec == "ELM") {
      if (!saw_nodes) c.fail("$Elements before $Nodes");
      if (d.major == 2) read_elements2(c, d); else read_elements4(c, d);
      saw_elements = true;
    } else c.skip_section(sec);
  }
  if (!saw_nodes) throw InputError(name, "no $Nodes section");
  if (!saw_elements) throw InputError(name, "no $Elements section");

  // --- node tags -> compact vertex indices, in the order the nodes were listed ---------------
  const std::size_t nn = d.node_tags.size();
  const std::uint64_t max_tag = nn ? *std::max_element(d.node_tags.begin(), d.node_tags.end()) : 0;
  const bool dense = max_tag <= 4 * nn + 1000000;
  std::vector<int> dense_map;
  std::unordered_map<std::uint64_t, int> sparse_map;
  if (dense) {
    dense_map.assign(max_tag + 1, -1);
    for (std::size_t i = 0; i < nn; ++i) dense_map[d.node_tags[i]] = static_cast<int>(i);
  } else {
    sparse_map.reserve(nn);
    for (std::size_t i = 0; i < nn; ++i) sparse_map[d.node_tags[i]] = static_cast<int>(i);
  }
  // Element `kind` number `element`'s node tag t -> index into d.node_tags.
  const auto node_index = [&](std::uint64_t t, const char* kind, std::size_t element) {
    int i = -1;
    if (dense) { if (t < dense_map.size()) i = dense_map[t]; }
    else if (auto it = sparse_map.find(t); it != sparse_map.end()) i = it->second;
    if (i < 0)
      throw InputError(name + ": " + kind + " " + std::to_string(element),
                       "node tag " + std::to_string(t) + " is not defined in $Nodes");
    return i;
  };
  std::vector<int> node_of(d.tri.size()), quad_of(d.quad.size());
  for (std::size_t k = 0; k < d.tri.size(); ++k) node_of[k] = node_index(d.tri[k], "triangle", k / 3);
  for (std::size_t k = 0; k < d.quad.size(); ++k) quad_of[k] = node_index(d.quad[k], "quadrangle", k / 4);
  std::vector<int> new_index(nn, -1);
  for (int i : node_of) new_index[i] = 0;
  for (int i : quad_of) new_index[i] = 0;
  int nv = 0;
  for (auto& x : new_index) if (x == 0) x = nv++;
  Mesh& m = out.mesh;
  m.V.resize(nv, 3);
  for (std::size_t i = 0; i < nn; ++i)
    if (new_index[i] >= 0)
      for (int k = 0; k < 3; ++k) m.V(new_index[i], k) = d.xyz[3 * i + k];
  std::vector<int> tri(node_of.size());
  for (std::size_t k = 0; k < node_of.size(); ++k) tri[k] = new_index[node_of[k]];
  // Quadrangles become two triangles each, cut along their shorter diagonal.
  std::vector<long long> poly(4);
  for (std::size_t q = 0; q < d.quad_entity.size(); ++q) {
    for (int j = 0; j < 4; ++j) poly[j] = new_index[quad_of[4 * q + j]];
    split_polygon(m.V, poly, tri);
    for (int t = 0; t < 2; ++t) {
      d.tri_entity.push_back(d.quad_entity[q]);
      d.tri_phys.push_back(d.quad_phys[q]);
    }
  }
  const std::size_t nt = d.tri_entity.size();
  m.F.resize(static_cast<Eigen::Index>(nt), 3);
  m.face_entity.resize(static_cast<Eigen::Index>(nt));
  for (std::size_t f = 0; f < nt; ++f) {
    for (int j = 0; j < 3; ++j) m.F(f, j) = tri[3 * f + j];
    m.face_entity[f] = d.tri_entity[f];
  }

  // --- physical groups of dimension 2 ---------------------------------------------------------
  std::map<int, std::vector<int>> groups;  // physical tag -> entities
  if (d.major == 2) {
    for (std::size_t f = 0; f < nt; ++f)
      if (d.tri_phys[f] != 0) groups[d.tri_phys[f]].push_back(d.tri_entity[f]);
  } else {
    for (const auto& [ent, phys] : d.surface_phys)
      for (int p : phys) groups[p].push_back(ent);
  }
  for (auto& [tag, ents] : groups) {
    std::sort(ents.begin(), ents.end());
    ents.erase(std::unique(ents.begin(), ents.end()), ents.end());
    PhysicalGroup g;
    g.tag = tag;
    if (auto it = d.names2.find(tag); it != d.names2.end()) g.name = it->second;
    g.entities = ents;
    m.physicals.push_back(std::move(g));
  }

  long long skipped = 0;
  std::string types;
  for (const auto& [t, k] : d.skipped_types) {
    skipped += k;
    types += (types.empty() ? "" : ", ") + std::to_string(k) + " of type " + std::to_string(t);
  }
  if (skipped)
    out.report.warnings.push_back(name + ": " + std::to_string(skipped) +
                                  " non-triangle elements ignored (" + types + ")");
  for (const auto& [t, k] : d.quad_types)
    out.report.warnings.push_back(name + ": " + std::to_string(k) + " quadrangles (type " + std::to_string(t) +
                                  ") split into two triangles each along their shorter diagonal" +
                                  (t != 3 ? ", corner nodes only" : ""));
  for (const auto& [t, k] : d.high_order_types)
    out.report.warnings.push_back(name + ": " + std::to_string(k) + " high-order triangles (type " +
                                  std::to_string(t) + "): only their 3 corner nodes were kept");
}

}  // namespace hocurve::io_detail
