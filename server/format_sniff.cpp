#include "server/format_sniff.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>

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

bool looks_like_obj(const std::string& text) {
  // Every non-empty line of an OBJ starts with a known keyword or '#'; require at least one "v ".
  size_t pos = 0, lines = 0;
  bool has_vertex = false;
  while (pos < text.size() && lines < 200) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = ltrim(text.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty()) continue;
    ++lines;
    static const char* kw[] = {"#", "v ", "vt", "vn", "vp", "f ", "o ", "g ", "s ", "l ", "mtllib", "usemtl", "v\t", "f\t"};
    bool ok = false;
    for (const char* k : kw)
      if (line.rfind(k, 0) == 0) { ok = true; break; }
    if (!ok) return false;
    if (line.rfind("v ", 0) == 0 || line.rfind("v\t", 0) == 0) has_vertex = true;
  }
  return has_vertex;
}

}  // namespace

SniffResult sniff_mesh(const std::string& head, std::uint64_t size, const std::string& name_hint) {
  SniffResult r;
  if (size == 0) {
    r.refusal = "the upload is empty";
    return r;
  }
  if (head.size() >= 2 && (unsigned char)head[0] == 0x1f && (unsigned char)head[1] == 0x8b) {
    // The worker inflates and detects the inner format; keep the inner extension when the name tells it.
    r.format = "gzip";
    r.extension = ".gz";
    for (const char* e : {".stl", ".obj", ".ply", ".off", ".msh"})
      if (ends_with_ci(name_hint, std::string(e) + ".gz")) r.extension = std::string(e) + ".gz";
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
  if (mostly_text(head) && looks_like_obj(head)) return {"obj", ".obj", ""};
  if (size < 84 && ends_with_ci(name_hint, ".stl")) {
    r.format = "stl-binary";
    r.refusal = "binary STL shorter than its 84-byte header (" + std::to_string(size) + " bytes)";
  }
  return r;
}

}  // namespace hocurve::server
