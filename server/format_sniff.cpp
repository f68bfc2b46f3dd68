#include "server/format_sniff.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <iterator>
#include <zlib.h>

namespace hocurve::server {
namespace {

bool starts_with_ci(const std::string& s, const char* p) {
  size_t n = std::strlen(p);
  if (s.size() < n) return false;
  for (size_t i = 0; i < n; ++i)
    if (std::tolower((unsigned char)s[i]) != std::tolower((unsigned char)p[i])) return false;
  return true;
}

std::string ltrim(const std::string& s) {
  size_t i = 0;
  // Skip a UTF-8 byte order mark and leading white space.
  if (s.size() >= 3 && (unsigned char)s[0] == 0xEF && (unsigned char)s[1] == 0xBB && (unsigned char)s[2] == 0xBF) i = 3;
  while (i < s.size() && std::isspace((unsigned char)s[i])) ++i;
  return s.substr(i);
}

bool mostly_text(const std::string& s) {
  size_t bad = 0;
  for (unsigned char c : s)
    if (c == 0 || (c < 32 && c != '\n' && c != '\r' && c != '\t')) ++bad;
  return bad == 0;
}

bool ends_with_ci(std::string s, const std::string& suffix) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Every line of an OBJ starts with a keyword (a statement) or '#'. The text must hold a vertex,
/// or be cut off (`truncated`) after nothing but OBJ statements: a file may open with many group,
/// object or material lines before its first vertex.
bool looks_like_obj(const std::string& text, bool truncated) {
  static const char* kw[] = {"v", "vt", "vn", "vp", "f", "o", "g", "s", "l", "p", "mtllib", "usemtl", "mg",
                             "cstype", "deg", "curv", "curv2", "surf", "parm", "trim", "hole", "end", "bevel",
                             "c_interp", "d_interp", "lod", "shadow_obj", "trace_obj", "ctech", "stech"};
  size_t pos = 0, lines = 0;
  bool has_vertex = false;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) {
      if (truncated) break;  // the last line may be cut in the middle of a word
      end = text.size();
    }
    std::string line = ltrim(text.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty() || line[0] == '#') continue;
    ++lines;
    const std::string word = line.substr(0, line.find_first_of(" \t\r"));
    if (std::find_if(std::begin(kw), std::end(kw), [&](const char* k) { return word == k; }) == std::end(kw))
      return false;
    has_vertex |= word == "v";
  }
  return has_vertex || (truncated && lines > 0);
}

/// The first `max_out` bytes a gzip stream inflates to (less if it ends or is corrupt first);
/// `ended` tells whether the stream ended within them.
std::string inflate_prefix(const std::string& gz, size_t max_out, bool& ended) {
  std::string out(max_out, '\0');
  z_stream z{};
  ended = false;
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) return "";
  z.next_in = (Bytef*)gz.data();
  z.avail_in = (uInt)gz.size();
  z.next_out = (Bytef*)out.data();
  z.avail_out = (uInt)out.size();
  const int rc = inflate(&z, Z_SYNC_FLUSH);
  ended = rc == Z_STREAM_END;
  out.resize(rc == Z_OK || rc == Z_STREAM_END || rc == Z_BUF_ERROR ? z.total_out : 0);
  inflateEnd(&z);
  return out;
}

}  // namespace

SniffResult sniff_mesh(const std::string& head, std::uint64_t size, const std::string& name_hint) {
  SniffResult r;
  if (size == 0) {
    r.refusal = "the upload is empty";
    return r;
  }
  if (head.size() >= 2 && (unsigned char)head[0] == 0x1f && (unsigned char)head[1] == 0x8b) {
    // The inner format is checked here on what the first 64 KiB inflate to: a gzip bomb of
    // zeros or of anything else but a mesh is refused before its worker inflates gigabytes.
    r.format = "gzip";
    r.extension = ".gz";
    for (const char* e : {".stl", ".obj", ".ply", ".off", ".msh"})
      if (ends_with_ci(name_hint, std::string(e) + ".gz")) r.extension = std::string(e) + ".gz";
    bool ended = false;
    const std::string inner = inflate_prefix(head, 64 * 1024, ended);
    if (inner.empty()) {
      r.refusal = "the gzip data is corrupt or empty";
      return r;
    }
    // Unknown total size: large enough for any facet count the header may declare.
    const SniffResult in = sniff_mesh(inner, ended ? inner.size() : ~0ull / 4, name_hint.substr(0, name_hint.size() - 3 * ends_with_ci(name_hint, ".gz")));
    if (in.format.empty()) return {};
    if (!in.refusal.empty()) r.refusal = "inside the gzip file: " + in.refusal;
    return r;
  }
  // Binary STL: 80-byte header, uint32 facet count, 50 bytes per facet. Checked before the text
  // formats because the header may start with "solid" too.
  if (size >= 84 && head.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, head.data() + 80, 4);
    bool exact = size == 84 + 50ull * n;
    bool ascii_solid = starts_with_ci(ltrim(head), "solid") && mostly_text(head.substr(0, std::min<size_t>(head.size(), 4096)));
    if (exact && n > 0 && !ascii_solid) {
      r.format = "stl-binary";
      r.extension = ".stl";
      return r;
    }
    if (!ascii_solid && !mostly_text(head.substr(0, std::min<size_t>(head.size(), 4096)))) {
      // Binary data that is no other format: judge it as a binary STL when its count is plausible.
      const std::uint64_t declared = 84 + 50ull * n;
      const bool stl_hint = ends_with_ci(name_hint, ".stl");
      const bool whole_facets = (size - 84) % 50 == 0;
      const bool near = declared <= 4 * size + 4096;  // truncated, not random bytes
      if (n > 0 && size > declared) return {"stl-binary", ".stl", ""};  // trailing bytes: the reader decides
      if (stl_hint || whole_facets || near) {
        r.format = "stl-binary";
        r.extension = ".stl";
        if (n == 0)
          r.refusal = "binary STL declares 0 facets";
        else if (whole_facets)
          r.refusal = "binary STL declares " + std::to_string(n) + " facets but its " + std::to_string(size) +
                      " bytes hold " + std::to_string((size - 84) / 50);
        else
          r.refusal = "binary STL declares " + std::to_string(n) + " facets (" + std::to_string(declared) +
                      " bytes) but the upload has " + std::to_string(size) + " bytes (truncated?)";
        return r;
      }
    }
  }
  std::string t = ltrim(head);
  if (starts_with_ci(t, "solid") && mostly_text(head)) return {"stl-ascii", ".stl", ""};
  if (t.rfind("$MeshFormat", 0) == 0) return {"msh", ".msh", ""};
  if (t.rfind("ply", 0) == 0 && t.size() > 3 && (t[3] == '\n' || t[3] == '\r')) return {"ply", ".ply", ""};
  if (t.rfind("OFF", 0) == 0 || t.rfind("NOFF", 0) == 0 || t.rfind("COFF", 0) == 0) return {"off", ".off", ""};
  if (mostly_text(head) && looks_like_obj(head, size > head.size())) return {"obj", ".obj", ""};
  if (size < 84 && ends_with_ci(name_hint, ".stl")) {
    r.format = "stl-binary";
    r.refusal = "binary STL shorter than its 84-byte header (" + std::to_string(size) + " bytes)";
  }
  return r;
}

}  // namespace hocurve::server
