// PLY: ascii, binary little- and big-endian. Reads vertex x,y,z and the face index list;
// every other element and property is skipped (but parsed, so its size is known).
#include "engine/core/error.hpp"
#include "engine/io/format_readers.hpp"
#include "engine/io/text_scanner.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace hocurve::io_detail {
namespace {

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64, none };

Type parse_type(const std::string& t) {
  if (t == "char" || t == "int8") return Type::i8;
  if (t == "uchar" || t == "uint8") return Type::u8;
  if (t == "short" || t == "int16") return Type::i16;
  if (t == "ushort" || t == "uint16") return Type::u16;
  if (t == "int" || t == "int32") return Type::i32;
  if (t == "uint" || t == "uint32") return Type::u32;
  if (t == "float" || t == "float32") return Type::f32;
  if (t == "double" || t == "float64") return Type::f64;
  return Type::none;
}

int type_size(Type t) {
  switch (t) {
    case Type::i8: case Type::u8: return 1;
    case Type::i16: case Type::u16: return 2;
    case Type::i32: case Type::u32: case Type::f32: return 4;
    case Type::f64: return 8;
    default: return 0;
  }
}

struct Property {
  std::string name;
  Type type = Type::none;       ///< item type
  Type count_type = Type::none; ///< list count type; none = scalar
};

struct Element {
  std::string name;
  unsigned long long count = 0;
  std::vector<Property> props;
  long long header_line = 0;
};

/// Reads binary numbers of either endianness from a bounded buffer.
class BinaryReader {
 public:
  BinaryReader(std::string_view b, std::size_t pos, bool big, const std::string& name)
      : b_(b), p_(pos), swap_(big != (std::endian::native == std::endian::big)), name_(name) {}
  double read(Type t, const std::string& where) {
    const int n = type_size(t);
    if (p_ + n > b_.size()) throw InputError(where, "unexpected end of binary data (the header's counts promise more)");
    unsigned char raw[8];
    std::memcpy(raw, b_.data() + p_, n);
    p_ += n;
    if (swap_) std::reverse(raw, raw + n);
    switch (t) {
      case Type::i8: { std::int8_t v; std::memcpy(&v, raw, 1); return v; }
      case Type::u8: return raw[0];
      case Type::i16: { std::int16_t v; std::memcpy(&v, raw, 2); return v; }
      case Type::u16: { std::uint16_t v; std::memcpy(&v, raw, 2); return v; }
      case Type::i32: { std::int32_t v; std::memcpy(&v, raw, 4); return v; }
      case Type::u32: { std::uint32_t v; std::memcpy(&v, raw, 4); return v; }
      case Type::f32: { float v; std::memcpy(&v, raw, 4); return v; }
      case Type::f64: { double v; std::memcpy(&v, raw, 8); return v; }
      default: return 0;
    }
  }
  std::size_t remaining() const { return b_.size() - p_; }

 private:
  std::string_view b_;
  std::size_t p_;
  bool swap_;
  const std::string& name_;
};

}  // namespace

void read_ply(std::string_view b, const std::string& name, ReadResult& out) {
  // --- header -------------------------------------------------------------------------------
  const std::size_t end_header = b.find("end_header");
  if (end_header == std::string_view::npos) throw InputError(name, "PLY header has no 'end_header' line");
  std::size_t data_start = b.find('\n', end_header);
  data_start = data_start == std::string_view::npos ? b.size() : data_start + 1;
  std::istringstream hs{std::string(b.substr(0, end_header))};
  std::string line, format;
  std::vector<Element> elems;
  long long ln = 0;
  while (std::getline(hs, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    const std::string where = name + ": line " + std::to_string(ln);
    if (kw.empty() || kw == "ply" || kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      ls >> format;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        throw InputError(where, "unknown PLY format '" + format + "'");
    } else if (kw == "element") {
      Element e;
      std::string count;
      ls >> e.name >> count;
      try {
        std::size_t used = 0;
        e.count = std::stoull(count, &used);
        if (used != count.size() || count[0] == '-') throw std::invalid_argument("");
      } catch (const std::exception&) {
        throw InputError(where, "bad element count '" + count + "'");
      }
      e.header_line = ln;
      elems.push_back(e);
    } else if (kw == "property") {
      if (elems.empty()) throw InputError(where, "property before any element");
      Property p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        p.count_type = parse_type(ct);
        p.type = parse_type(it);
        if (p.count_type == Type::none || p.count_type == Type::f32 || p.count_type == Type::f64 || p.type == Type::none)
          throw InputError(where, "bad list property types '" + ct + " " + it + "'");
      } else {
        p.type = parse_type(t);
        ls >> p.name;
        if (p.type == Type::none) throw InputError(where, "unknown property type '" + t + "'");
      }
      elems.back().props.push_back(p);
    } else {
      throw InputError(where, "unknown PLY header keyword '" + kw + "'");
    }
  }
  if (format.empty()) throw InputError(name, "PLY header has no 'format' line");

  // --- which properties we keep ---------------------------------------------------------------
  const Element* ve = nullptr;
  const Element* fe = nullptr;
  int xyz[3] = {-1, -1, -1}, fidx = -1;
  for (const auto& e : elems) {
    if (e.name == "vertex" && !ve) {
      ve = &e;
      for (int i = 0; i < static_cast<int>(e.props.size()); ++i)
        for (int d = 0; d < 3; ++d)
          if (e.props[i].name == std::string(1, "xyz"[d]) && e.props[i].count_type == Type::none) xyz[d] = i;
    }
    if (e.name == "face" && !fe) {
      fe = &e;
      for (int i = 0; i < static_cast<int>(e.props.size()); ++i)
        if ((e.props[i].name == "vertex_indices" || e.props[i].name == "vertex_index") &&
            e.props[i].count_type != Type::none)
          fidx = i;
    }
  }
  if (!ve) throw InputError(name, "PLY has no 'vertex' element");
  if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) throw InputError(name, "PLY vertex element lacks x, y or z");
  if (!fe) throw InputError(name, "PLY has no 'face' element (no triangles)");
  if (fidx < 0) throw InputError(name, "PLY face element has no 'vertex_indices' list");
  // Lying counts: every element needs at least one byte per scalar; refuse before allocating.
  const std::size_t avail = b.size() - data_start;
  for (const auto& e : elems) {
    const unsigned long long per = std::max<std::size_t>(1, e.props.size());
    if (e.count > avail / per + 1)
      throw InputError(name + ": line " + std::to_string(e.header_line),
                       "element '" + e.name + "' declares " + std::to_string(e.count) + " items but only " +
                           std::to_string(avail) + " bytes of data follow");
  }
  if (ve->count > static_cast<unsigned long long>(INT32_MAX)) throw InputError(name, "too many vertices");

  Mesh& m = out.mesh;
  m.V.resize(static_cast<Eigen::Index>(ve->count), 3);
  const long long nv = static_cast<long long>(ve->count);
  PolygonFaces faces;
  // Indices arrive as doubles (any list item type, float included): converting one beyond long long
  // is undefined, so anything but a whole number in [0, nv) is refused here, with its value.
  auto index = [&](double v, const std::string& where) {
    if (!(v >= 0 && v < static_cast<double>(nv)) || v != std::floor(v)) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.10g", v);
      throw InputError(where, std::string("vertex index ") + buf + " out of range (the file has " +
                                  std::to_string(nv) + " vertices)");
    }
    return static_cast<long long>(v);
  };

  if (format == "ascii") {
    TextScanner sc(b, name);
    sc.seek(data_start);
    // Line numbers restart at the data: count the header's lines once.
    const long long header_lines = std::count(b.begin(), b.begin() + data_start, '\n');
    auto where = [&](const Element& e, unsigned long long i) {
      return name + ": line " + std::to_string(sc.line() + header_lines) + ": " + e.name + " " + std::to_string(i);
    };
    for (const auto& e : elems) {
      const bool is_v = &e == ve, is_f = &e == fe;
      for (unsigned long long i = 0; i < e.count; ++i) {
        for (int pi = 0; pi < static_cast<int>(e.props.size()); ++pi) {
          const Property& p = e.props[pi];
          auto num = [&]() {
            const std::string_view t = sc.token();
            if (t.empty()) throw InputError(where(e, i), "unexpected end of file (the header's counts promise more)");
            double v = 0;
            const char* first = t.data() + (t[0] == '+' ? 1 : 0);
            auto [q, ec] = std::from_chars(first, t.data() + t.size(), v);
            if (ec != std::errc() || q != t.data() + t.size())
              throw InputError(where(e, i), "expected a number, found '" + std::string(t.substr(0, 40)) + "'");
            return v;
          };
          if (p.count_type == Type::none) {
            const double v = num();
            if (is_v) for (int d = 0; d < 3; ++d) if (pi == xyz[d]) m.V(static_cast<Eigen::Index>(i), d) = v;
          } else {
            const double c = num();
            if (c < 0 || c != std::floor(c) || c > 1e6) throw InputError(where(e, i), "bad list length");
            for (long long k = 0; k < static_cast<long long>(c); ++k) {
              const double v = num();
              if (is_f && pi == fidx) faces.corner(index(v, where(e, i)));
            }
            if (is_f && pi == fidx) faces.end_face();
          }
        }
      }
    }
  } else {
    BinaryReader br(b, data_start, format == "binary_big_endian", name);
    for (const auto& e : elems) {
      const bool is_v = &e == ve, is_f = &e == fe;
      for (unsigned long long i = 0; i < e.count; ++i) {
        const std::string where = name + ": " + e.name + " " + std::to_string(i);
        for (int pi = 0; pi < static_cast<int>(e.props.size()); ++pi) {
          const Property& p = e.props[pi];
          if (p.count_type == Type::none) {
            const double v = br.read(p.type, where);
            if (is_v) for (int d = 0; d < 3; ++d) if (pi == xyz[d]) m.V(static_cast<Eigen::Index>(i), d) = v;
          } else {
            const double c = br.read(p.count_type, where);
            if (c < 0) throw InputError(where, "negative list length");
            if (static_cast<unsigned long long>(c) * type_size(p.type) > br.remaining())
              throw InputError(where, "list of " + std::to_string(static_cast<long long>(c)) +
                                          " items runs past the end of the file");
            for (long long k = 0; k < static_cast<long long>(c); ++k) {
              const double v = br.read(p.type, where);
              if (is_f && pi == fidx) faces.corner(index(v, where));
            }
            if (is_f && pi == fidx) faces.end_face();
          }
        }
      }
    }
  }
  faces.to_triangles(m, name, out.report);
  out.report.format = format == "ascii" ? "ply-ascii" : "ply-binary";
}

}  // namespace hocurve::io_detail
