#include "engine/io/validate_mesh.hpp"

#include "engine/core/error.hpp"
#include "engine/core/topology.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

namespace hocurve {
namespace {

std::string plural(long long n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

/// Keeps the faces with keep[f] (and their entity tags).
void keep_faces(Mesh& m, const std::vector<char>& keep) {
  const int nf = m.num_faces();
  int k = 0;
  for (int f = 0; f < nf; ++f) {
    if (!keep[f]) continue;
    m.F.row(k) = m.F.row(f);
    if (m.face_entity.size()) m.face_entity[k] = m.face_entity[f];
    ++k;
  }
  m.F.conservativeResize(k, 3);
  if (m.face_entity.size()) m.face_entity.conservativeResize(k);
}

bool zero_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double l2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  // Relative test: |cross| = 2 area; collinear corners leave only rounding noise (~1e-16 l^2).
  return (b - a).cross(c - a).norm() <= kZeroArea * l2;
}

bool face_zero_area(const Mesh& m, int f) {
  return zero_area(m.V.row(m.F(f, 0)), m.V.row(m.F(f, 1)), m.V.row(m.F(f, 2)));
}

/// Removes zero-area caps: a face (a, b, m) whose m lies inside its longest edge ab closes a
/// T-junction; with the face g = (a, b, x) across ab it is replaced by g split at m, (a, m, x)
/// and (m, b, x) (an edge flip). The two new faces cover exactly g, so the surface is unchanged,
/// and no element of it has zero area any more. Skipped where ab is not shared by exactly two
/// faces, the new edge m-x exists already or a new face would have zero area. Returns the count.
long long flip_zero_area_caps(Mesh& m) {
  long long flipped = 0;
  for (int pass = 0; pass < 8; ++pass) {
    const Topology T = build_topology(m.F, m.num_vertices());
    std::vector<char> touched(m.num_faces(), 0);
    long long before = flipped;
    for (int f = 0; f < m.num_faces(); ++f) {
      if (touched[f]) continue;
      if (!face_zero_area(m, f)) continue;
      const Eigen::Vector3d x0 = m.V.row(m.F(f, 0)), x1 = m.V.row(m.F(f, 1)), x2 = m.V.row(m.F(f, 2));
      const double l[3] = {(x2 - x1).squaredNorm(), (x0 - x2).squaredNorm(), (x1 - x0).squaredNorm()};
      const int j = static_cast<int>(std::max_element(l, l + 3) - l);  // corner opposite the longest edge
      const int mid = m.F(f, j), a = m.F(f, (j + 1) % 3), b = m.F(f, (j + 2) % 3);
      const Eigen::Vector3d pa = m.V.row(a), pb = m.V.row(b), pm = m.V.row(mid);
      const double t = (pm - pa).dot(pb - pa) / (pb - pa).squaredNorm();
      if (!(t > 1e-6 && t < 1 - 1e-6)) continue;
      const int edge = T.FE(f, (j + 1) % 3);  // a-b: FE(f, k) joins corners k and k + 1
      if (T.edge_faces[edge].size() != 2) continue;
      const int g = T.edge_faces[edge][0] == f ? T.edge_faces[edge][1] : T.edge_faces[edge][0];
      if (touched[g]) continue;
      int xi = 0;  // g = (p, q, x) in its own cyclic order with {p, q} = {a, b}
      while (m.F(g, xi) == a || m.F(g, xi) == b) ++xi;
      const int x = m.F(g, xi), p = m.F(g, (xi + 1) % 3), q = m.F(g, (xi + 2) % 3);
      bool exists = false;
      for (auto [eb, ee] = T.edges_of(mid); eb != ee; ++eb) exists |= T.E(*eb, 0) == x || T.E(*eb, 1) == x;
      const Eigen::Vector3d px = m.V.row(x);
      if (exists || zero_area(m.V.row(p), pm, px) || zero_area(pm, m.V.row(q), px)) continue;
      m.F.row(f) << p, mid, x;
      m.F.row(g) << mid, q, x;
      if (m.face_entity.size()) m.face_entity[f] = m.face_entity[g];
      touched[f] = touched[g] = 1;
      ++flipped;
    }
    if (flipped == before) break;
  }
  return flipped;
}

/// Zero-area faces at most one of whose edges another face uses (a flap hanging on an edge, a
/// lone collinear triangle): removing them opens no hole (their other edges bound nothing else)
/// and changes no surface. Returns the count removed.
long long drop_zero_area_flaps(Mesh& m) {
  const Topology T = build_topology(m.F, m.num_vertices());
  std::vector<char> keep(m.num_faces(), 1);
  long long dropped = 0;
  for (int f = 0; f < m.num_faces(); ++f) {
    if (!face_zero_area(m, f)) continue;
    int shared = 0;
    for (int k = 0; k < 3; ++k) shared += T.edge_faces[T.FE(f, k)].size() > 1;
    if (shared <= 1) keep[f] = 0, ++dropped;
  }
  if (dropped) keep_faces(m, keep);
  return dropped;
}

/// Does face f walk the edge a->b (rather than b->a)?
bool walks(const Mesh& m, int f, int a, int b) {
  for (int j = 0; j < 3; ++j)
    if (m.F(f, j) == a && m.F(f, (j + 1) % 3) == b) return true;
  return false;
}

}  // namespace

ValidateReport validate_mesh(Mesh& m, const ValidateOptions& opt) {
  ValidateReport r;
  const std::string& name = opt.name;
  auto warn = [&](const std::string& s) { r.warnings.push_back(name.empty() ? s : name + ": " + s); };

  // --- fatal checks ---------------------------------------------------------------------------
  if (m.F.rows() == 0) throw InputError(name, "no triangles");
  if (m.F.cols() != 3) throw InputError(name, "faces are not triangles");
  if (m.V.cols() != 3) throw InputError(name, "vertices are not 3D points");
  if (m.face_entity.size() && m.face_entity.size() != m.F.rows())
    throw InputError(name, "face_entity has " + std::to_string(m.face_entity.size()) + " entries for " +
                               std::to_string(m.F.rows()) + " faces");
  static constexpr const char* axis[] = {"x", "y", "z"};
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(m.V(v, d)))
        throw InputError(name + (name.empty() ? "" : ": ") + "vertex " + std::to_string(v),
                         std::string("has ") + (std::isnan(m.V(v, d)) ? "a NaN" : "an infinite") + " " + axis[d] +
                             " coordinate");
  const int nv0 = m.num_vertices();
  for (int f = 0; f < m.num_faces(); ++f)
    for (int j = 0; j < 3; ++j)
      if (m.F(f, j) < 0 || m.F(f, j) >= nv0)
        throw InputError(name + (name.empty() ? "" : ": ") + "face " + std::to_string(f),
                         "vertex index " + std::to_string(m.F(f, j)) + " out of range [0, " + std::to_string(nv0) + ")");

  // --- size: products of lengths (areas squared, cross products of cross products) must neither
  // overflow nor underflow; measured, the curving is unchanged from 1e-60 to 1e30 and goes wrong
  // by 1e40 (spurious creases) and 1e80 (every face degenerate), so refuse rather than curve badly.
  {
    Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (int f = 0; f < m.num_faces(); ++f)  // the vertices faces use: unused ones are dropped below
      for (int j = 0; j < 3; ++j) lo = lo.cwiseMin(m.V.row(m.F(f, j))), hi = hi.cwiseMax(m.V.row(m.F(f, j)));
    const double diag = (hi - lo).stableNorm();  // 1e200 coordinates: a finite diagonal, not inf
    if (diag > kMaxDiagonal || (diag > 0 && diag < kMinDiagonal)) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "the bounding box diagonal is %.3g, outside the %g to %g hocurve works in; rescale the mesh (change its units)",
                    diag, kMinDiagonal, kMaxDiagonal);
      throw InputError(name, buf);
    }
  }

  // --- degenerate and duplicate faces ---------------------------------------------------------
  {
    const int nf = m.num_faces();
    std::vector<char> keep(nf, 1);
    int first_degenerate = -1;
    for (int f = 0; f < nf; ++f)
      if (m.F(f, 0) == m.F(f, 1) || m.F(f, 1) == m.F(f, 2) || m.F(f, 0) == m.F(f, 2)) {
        ++r.degenerate_faces;
        if (first_degenerate < 0) first_degenerate = f;
        if (opt.drop_degenerate_faces) keep[f] = 0;
      }
    // Duplicates: same three vertices in any order; sort keys, keep the first occurrence.
    std::vector<std::array<int, 4>> key;
    key.reserve(nf);
    for (int f = 0; f < nf; ++f) {
      if (!keep[f]) continue;
      std::array<int, 4> k = {m.F(f, 0), m.F(f, 1), m.F(f, 2), f};
      std::sort(k.begin(), k.begin() + 3);
      key.push_back(k);
    }
    std::sort(key.begin(), key.end());
    int first_dup = -1, first_dup_of = -1;
    for (std::size_t i = 1; i < key.size(); ++i)
      if (key[i][0] == key[i - 1][0] && key[i][1] == key[i - 1][1] && key[i][2] == key[i - 1][2]) {
        ++r.duplicate_faces;
        if (first_dup < 0 || key[i][3] < first_dup) first_dup = key[i][3], first_dup_of = key[i - 1][3];
        if (opt.drop_duplicate_faces) keep[key[i][3]] = 0;
        key[i][3] = key[i - 1][3];  // later repeats point at the first occurrence
      }
    if (r.degenerate_faces)
      warn(plural(r.degenerate_faces, "degenerate face", "degenerate faces") + " (repeated vertex index), first: face " +
           std::to_string(first_degenerate) + (opt.drop_degenerate_faces ? "; removed" : ""));
    if (r.duplicate_faces)
      warn(plural(r.duplicate_faces, "duplicate face", "duplicate faces") + ", first: face " + std::to_string(first_dup) +
           " repeats face " + std::to_string(first_dup_of) + (opt.drop_duplicate_faces ? "; removed" : ""));
    if (r.degenerate_faces + r.duplicate_faces) keep_faces(m, keep);
    if (m.F.rows() == 0) throw InputError(name, "no usable triangles (all degenerate or duplicate)");
  }

  // --- zero-area faces: caps flipped away, flaps removed, the rest kept (removing them opens holes)
  {
    int first = -1;
    for (int f = 0; f < m.num_faces(); ++f)
      if (face_zero_area(m, f)) {
        ++r.zero_area_faces;
        if (first < 0) first = f;
      }
    if (r.zero_area_faces && opt.flip_zero_area_caps) r.zero_area_caps_flipped = flip_zero_area_caps(m);
    if (r.zero_area_faces && opt.drop_zero_area_flaps) r.zero_area_flaps_removed = drop_zero_area_flaps(m);
    if (r.zero_area_faces)
      warn(plural(r.zero_area_faces, "zero-area face", "zero-area faces") + " (collinear corners), first: face " +
           std::to_string(first) +
           (r.zero_area_caps_flipped ? "; " + std::to_string(r.zero_area_caps_flipped) +
                                           " closed T-junctions and were flipped into their neighbours (same surface)"
                                     : std::string()) +
           (r.zero_area_flaps_removed ? "; " + std::to_string(r.zero_area_flaps_removed) +
                                            " hung on one edge or on none and were removed (same surface)"
                                      : std::string()));
    bool any_area = r.zero_area_faces == 0;
    for (int f = 0; f < m.num_faces() && !any_area; ++f) any_area = !face_zero_area(m, f);
    if (!any_area) throw InputError(name, "no usable triangles (every face has zero area: all corners collinear)");
  }

  // --- unused vertices (also those only removed faces used) -----------------------------------
  {
    std::vector<int> remap(m.num_vertices(), -1);
    for (int f = 0; f < m.num_faces(); ++f)
      for (int j = 0; j < 3; ++j) remap[m.F(f, j)] = 0;
    int nv = 0;
    for (auto& x : remap) x = x == 0 ? nv++ : -1;
    r.unused_vertices = m.num_vertices() - nv;
    if (r.unused_vertices && opt.drop_unused_vertices) {
      Eigen::MatrixXd V(nv, 3);
      for (int v = 0; v < m.num_vertices(); ++v)
        if (remap[v] >= 0) V.row(remap[v]) = m.V.row(v);
      m.V.swap(V);
      for (int f = 0; f < m.num_faces(); ++f)
        for (int j = 0; j < 3; ++j) m.F(f, j) = remap[m.F(f, j)];
      warn(plural(r.unused_vertices, "unused vertex", "unused vertices") + " removed");
    } else if (r.unused_vertices) {
      warn(plural(r.unused_vertices, "unused vertex", "unused vertices"));
    }
  }

  const int nf = m.num_faces(), nv = m.num_vertices();


  // --- topology: boundary, non-manifold edges and vertices -------------------------------------
  const Topology T = build_topology(m.F, nv);
  // One flat copy of edge -> faces: the loops below touch it many times, and one vector per
  // edge costs a cache miss per access on large meshes.
  std::vector<int> ef_start(T.num_edges() + 1, 0), ef_items;
  for (int e = 0; e < T.num_edges(); ++e) ef_start[e + 1] = ef_start[e] + static_cast<int>(T.edge_faces[e].size());
  ef_items.reserve(ef_start.back());
  for (const auto& ef : T.edge_faces) ef_items.insert(ef_items.end(), ef.begin(), ef.end());
  auto faces_on = [&](int e) { return std::pair<const int*, const int*>{ef_items.data() + ef_start[e], ef_items.data() + ef_start[e + 1]}; };
  auto n_faces_on = [&](int e) { return ef_start[e + 1] - ef_start[e]; };
  int first_nm_edge = -1;
  for (int e = 0; e < T.num_edges(); ++e) {
    const auto k = n_faces_on(e);
    if (k == 1) ++r.boundary_edges;
    if (k > 2) {
      ++r.nonmanifold_edges;
      if (first_nm_edge < 0) first_nm_edge = e;
    }
  }
  if (r.boundary_edges) warn(plural(r.boundary_edges, "boundary edge", "boundary edges") + " (the surface is open)");
  if (r.nonmanifold_edges)
    warn(plural(r.nonmanifold_edges, "non-manifold edge", "non-manifold edges") + " (more than 2 faces), first: vertices " +
         std::to_string(T.E(first_nm_edge, 0)) + "-" + std::to_string(T.E(first_nm_edge, 1)));
  {
    // A vertex is non-manifold when its faces do not form one fan joined through its edges.
    std::vector<int> parent;
    int first = -1;
    for (int v = 0; v < nv; ++v) {
      const auto [fb, fe] = T.faces_of(v);
      const int k = static_cast<int>(fe - fb);
      if (k <= 1) continue;
      parent.resize(k);
      std::iota(parent.begin(), parent.end(), 0);
      auto find = [&](int x) { while (parent[x] != x) x = parent[x] = parent[parent[x]]; return x; };
      // Explicit captures: clang 14 (the fuzzing build) cannot capture structured bindings by [&].
      auto local = [fb = fb, fe = fe](int f) { return static_cast<int>(std::lower_bound(fb, fe, f) - fb); };
      int groups = k;
      const auto [eb, ee] = T.edges_of(v);
      for (const int* e = eb; e != ee && groups > 1; ++e) {
        const auto [b0, b1] = faces_on(*e);
        for (const int* g = b0 + 1; g < b1; ++g) {
          const int x = find(local(*b0)), y = find(local(*g));
          if (x != y) parent[x] = y, --groups;
        }
      }
      if (groups > 1) {
        ++r.nonmanifold_vertices;
        if (first < 0) first = v;
      }
    }
    if (r.nonmanifold_vertices)
      warn(plural(r.nonmanifold_vertices, "non-manifold vertex", "non-manifold vertices") +
           " (faces around it form separate fans), first: vertex " + std::to_string(first));
  }

  // --- components (edge-connected) and orientation (through manifold edges) --------------------
  std::vector<int> comp(nf, -1);
  std::vector<int> queue;
  queue.reserve(nf);
  for (int s = 0; s < nf; ++s) {
    if (comp[s] >= 0) continue;
    const int c = r.components++;
    queue.clear();
    queue.push_back(s);
    comp[s] = c;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const int f = queue[q];
      for (int j = 0; j < 3; ++j) {
        const auto [b0, b1] = faces_on(T.FE(f, j));
        for (const int* g = b0; g < b1; ++g)
          if (comp[*g] < 0) comp[*g] = c, queue.push_back(*g);
      }
    }
  }
  if (r.components > 1) {
    // Most faces alone: a triangle soup, each face with its own copies of its corners, which the
    // reader's weld did not merge; nothing curves across a boundary.
    const bool soup = nf >= 4 && 2LL * r.components > nf;
    warn(std::to_string(r.components) + " connected components" +
         (soup ? " (most faces share no edge: a triangle soup whose copies of one vertex differ by more than the "
                 "weld tolerance? hocurve --weld-tolerance F merges vertices within F x the bounding-box diagonal)"
               : ""));
  }

  if (opt.fix_orientation) {
    // BFS over manifold edges: flip[g] says whether g must be reversed to agree with the seed.
    std::vector<signed char> flip(nf, -1);
    std::vector<char> flip_final(nf, 0);
    long long first_bad_face = -1;
    for (int s = 0; s < nf; ++s) {
      if (flip[s] >= 0) continue;
      queue.clear();
      queue.push_back(s);
      flip[s] = 0;
      bool orientable = true;
      for (std::size_t q = 0; q < queue.size(); ++q) {
        const int f = queue[q];
        for (int j = 0; j < 3; ++j) {
          const int e = T.FE(f, j);
          if (n_faces_on(e) != 2) continue;
          const int* ef = faces_on(e).first;
          const int g = ef[0] == f ? ef[1] : ef[0];
          const int a = m.F(f, j), b = m.F(f, (j + 1) % 3);
          // Consistent neighbours walk the shared edge in opposite directions.
          const signed char want = static_cast<signed char>(flip[f] ^ (walks(m, g, a, b) ? 1 : 0));
          if (flip[g] < 0) flip[g] = want, queue.push_back(g);
          else if (flip[g] != want) {
            orientable = false;
            if (first_bad_face < 0) first_bad_face = g;
          }
        }
      }
      if (!orientable) { ++r.non_orientable_components; continue; }
      long long n_flip = 0;
      for (int f : queue) n_flip += flip[f];
      // Flip the minority so that as few faces as possible change.
      const bool invert = 2 * n_flip > static_cast<long long>(queue.size());
      for (int f : queue) flip_final[f] = static_cast<char>(flip[f] ^ (invert ? 1 : 0));
      if (opt.orient_outward) {
        // A closed patch (no boundary or non-manifold edge) should enclose positive volume.
        bool closed = true;
        double vol = 0;
        for (int f : queue) {
          for (int j = 0; j < 3; ++j)
            if (n_faces_on(T.FE(f, j)) != 2) closed = false;
          const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
          vol += (flip_final[f] ? -1.0 : 1.0) * a.dot(b.cross(c));
        }
        if (closed && vol < 0) {
          for (int f : queue) flip_final[f] ^= 1;
          ++r.outward_flipped_components;
        }
      }
    }
    for (int f = 0; f < nf; ++f)
      if (flip_final[f]) {
        std::swap(m.F(f, 1), m.F(f, 2));
        ++r.flipped_faces;
      }
    if (r.flipped_faces)
      warn(plural(r.flipped_faces, "face", "faces") + " flipped for consistent orientation" +
           (r.outward_flipped_components
                ? " (" + plural(r.outward_flipped_components, "closed component", "closed components") +
                      " turned outward)"
                : std::string()));
    if (r.non_orientable_components)
      warn(plural(r.non_orientable_components, "component is", "components are") +
           " not orientable (left as read), first conflict at face " + std::to_string(first_bad_face));
  }
  return r;
}

}  // namespace hocurve
