#include "engine/curving/share_exact_fits.hpp"

#include "engine/core/union_find.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace hocurve {

LocalFit exact_surface_fit(std::shared_ptr<const ExactQuadric> surface, const LocalFit& fit, int p) {
  LocalFit F;
  F.surface = std::move(surface);
  F.o = fit.o;
  F.h = fit.h;
  F.n = F.surface->gradient(F.o).normalized();
  if (F.n.dot(fit.n) < 0) F.n = -F.n;
  tangent_frame(F.n, F.t1, F.t2);
  F.exact = true;
  F.degree = F.requested_degree = p;
  F.c = Eigen::VectorXd::Zero(fit_coefficients(p));
  F.pivot_ratio = 1;
  return F;
}

namespace {

/// Wedge w has no exact fit (nor a cone model), and its faces turn from its fit's normal by more
/// than min_turn_deg, or it is one-sided: where fit_wedge tries its own. Below, its height fit is
/// closer than a quadric fitted to rounding (a 20k-triangle ellipsoid's flatter half took its
/// neighbours' quadrics: P4 1.9e-8 -> 7.0e-9 from 5k triangles, not 6e-10).
bool may_take(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits, int w, const ExactQuadricOptions& opt) {
  return !fits[w].exact && !fits[w].apex && !W.is_cone(W.wedge_vertex[w]) &&
         (W.one_sided(w) || wedge_turn_deg(mesh, W, w, fits[w].n) > opt.min_turn_deg);
}

/// Face f wants a surface of its own: some corner's fit is not exact, and every such corner may
/// take one (may_take; no cone model among them). Where a corner's faces turn by less than 2
/// degrees its height fit is closer than a quadric fitted to rounding (cut sphere h = 0.05: faces
/// on their neighbours' quadrics took P4 2.2e-10 -> 3.3e-7).
bool wants_surface(const Mesh& mesh, const Wedges& W, const std::vector<LocalFit>& fits, int f,
                   const ExactQuadricOptions& opt) {
  bool all_exact = true;
  for (int j = 0; j < 3; ++j) {
    const int w = W.corner_wedge(f, j);
    if (fits[w].apex || (!fits[w].exact && !may_take(mesh, W, fits, w, opt))) return false;
    all_exact = all_exact && fits[w].exact;
  }
  return !all_exact;
}

}  // namespace

bool face_on(const Mesh& mesh, int f, const ExactQuadric& Q, const ExactQuadricOptions& opt, double& side,
             const Wedges* W) {
  for (int j = 0; j < 3; ++j) {
    const bool feature = W && W->vertex_wedges(mesh.F(f, j)) > 1;
    if (!(Q.distance(mesh.V.row(mesh.F(f, j)).transpose()) <= (feature ? opt.clear_factor : opt.on_factor) * Q.tolerance))
      return false;
  }
  return face_agrees(mesh, f, Q, opt, side);
}

bool wedge_faces_on(const Mesh& mesh, const Wedges& W, int w, const ExactQuadric& Q, const ExactQuadricOptions& opt) {
  double side = 0;
  for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1]; ++i)
    if (!face_on(mesh, W.wedge_faces[i], Q, opt, side, &W)) return false;
  return side != 0;
}

std::vector<const LocalFit*> face_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W,
                                             const std::vector<LocalFit>& fits, const ExactQuadricOptions& opt) {
  const int nf = mesh.num_faces();
  std::vector<const LocalFit*> out(nf, nullptr);
  if (std::none_of(fits.begin(), fits.end(), [](const LocalFit& F) { return F.exact; })) return out;
  tbb::parallel_for(tbb::blocked_range<int>(0, nf, 256), [&](const tbb::blocked_range<int>& r) {
    std::vector<const LocalFit*> found;
    for (int f = r.begin(); f < r.end(); ++f) {
      if (!wants_surface(mesh, W, fits, f, opt)) continue;
      found.clear();
      for (int j = 0; j < 3; ++j)
        for (auto [b, e] = T.faces_of(mesh.F(f, j)); b != e; ++b)
          for (int k = 0; k < 3; ++k) {
            const LocalFit* F = &fits[W.corner_wedge(*b, k)];
            if (!F->exact || F->apex || std::find(found.begin(), found.end(), F) != found.end()) continue;
            double side = 0;
            if (face_on(mesh, f, *F->surface, opt, side, &W)) found.push_back(F);
          }
      if (found.empty()) continue;
      // Two surfaces through the three corners (a face with every corner on a junction curve)
      // leave the face's side unknown: then none.
      const Eigen::Vector3d c = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3;
      const Eigen::Vector3d x0 = found[0]->project(c);
      bool agree = true;
      for (const LocalFit* F : found)
        agree = agree && (F->project(c) - x0).norm() <=
                             opt.clear_factor * std::max(F->surface->tolerance, found[0]->surface->tolerance);
      if (agree) out[f] = found[0];
    }
  });
  return out;
}

namespace {

/// The exact surface tangent at v: the first exact fit of a corner of a face at v outside wedge
/// w (-1: any) that passes through v (null if none); its normal there in n.
const ExactQuadric* tangent_normal(const Mesh& mesh, const Topology& T, const Wedges& W,
                                   const std::vector<LocalFit>& fits, int w, int v, Eigen::Vector3d& n) {
  const Eigen::Vector3d x = mesh.V.row(v).transpose();
  for (auto [b, e] = T.faces_of(v); b != e; ++b) {
    int j = 0;
    while (mesh.F(*b, j) != v) ++j;
    if (W.corner_wedge(*b, j) == w) continue;
    for (int k = 0; k < 3; ++k) {
      const LocalFit& F = fits[W.corner_wedge(*b, k)];
      if (F.exact && F.surface->contains(x)) {
        n = F.surface->gradient(x).normalized();
        return n.allFinite() ? F.surface.get() : nullptr;
      }
    }
  }
  return nullptr;
}

/// Wedge w's quadric through its faces' corners, tangent to the exact surfaces through them
/// (fit_tangent_quadric; valid false where none is determined).
ExactQuadric tangent_wedge_quadric(const Mesh& mesh, const Topology& T, const Wedges& W,
                                   const std::vector<LocalFit>& fits, int w, const ExactQuadricOptions& opt) {
  const std::vector<int> verts =
      face_corners(mesh, W.wedge_faces.data() + W.wedge_start[w], W.wedge_faces.data() + W.wedge_start[w + 1]);
  Eigen::MatrixXd P(verts.size(), 3), X(verts.size(), 3), N(verts.size(), 3);
  int m = 0;
  std::vector<const ExactQuadric*> tangent;
  for (size_t i = 0; i < verts.size(); ++i) {
    P.row(i) = mesh.V.row(verts[i]);
    Eigen::Vector3d n;
    if (const ExactQuadric* S = tangent_normal(mesh, T, W, fits, w, verts[i], n)) {
      X.row(m) = P.row(i), N.row(m++) = n.transpose();
      if (std::find(tangent.begin(), tangent.end(), S) == tangent.end()) tangent.push_back(S);
    }
  }
  // Some corner must lie clearly off every surface it is tangent to: else the faces are on those
  // surfaces (needles whose normals disagree with them), and a quadric tangent to them at a few
  // close points only osculates them (a marching-tetrahedra torus: P4 2.5e-6 -> 3.9e-4).
  auto clearly_off = [&](Eigen::Index i) {
    return std::all_of(tangent.begin(), tangent.end(), [&](const ExactQuadric* S) {
      return S->distance(P.row(i).transpose()) >= opt.clear_factor * S->tolerance;
    });
  };
  ExactQuadric Q;
  bool off = false;
  for (Eigen::Index i = 0; i < P.rows() && !off; ++i) off = clearly_off(i);
  if (m < 2 || !off) return Q;
  Q = fit_tangent_quadric(P, X.topRows(m), N.topRows(m));
  Q.tolerance = opt.relative_tolerance() * P.rowwise().norm().maxCoeff();
  Q.valid = determined(Q, Q.tolerance, opt) && !reducible(Q) && wedge_faces_on(mesh, W, w, Q, opt);
  return Q;
}

/// The surface of one region of free faces (wants_surface, held by no exact fit) joined across
/// smooth edges (faces sharing an edge in
/// one wedge at both its ends): the quadric, else the cyclide, through its corners and tangent to
/// the exact surfaces through them (fit_tangent_quadric, fit_tangent_cyclide); valid false where
/// none is determined or holds every face. Why a region: a torus fillet two rows across has a
/// middle row whose fans alone (7 points, 4 rim normals) do not determine a cyclide (13 unknowns).
ExactQuadric tangent_region_surface(const Mesh& mesh, const Topology& T, const Wedges& W,
                                    const std::vector<LocalFit>& fits, const std::vector<int>& faces,
                                    const ExactQuadricOptions& opt) {
  const std::vector<int> verts = face_corners(mesh, faces.data(), faces.data() + faces.size());
  Eigen::MatrixXd P(verts.size(), 3), X(verts.size(), 3), N(verts.size(), 3);
  int m = 0;
  bool off = false;
  for (size_t i = 0; i < verts.size(); ++i) {
    P.row(i) = mesh.V.row(verts[i]);
    Eigen::Vector3d n;
    if (tangent_normal(mesh, T, W, fits, -1, verts[i], n))
      X.row(m) = P.row(i), N.row(m++) = n.transpose();
    else
      off = true;  // on no exact surface: the region is not merely its neighbours' faces
  }
  ExactQuadric Q;
  if (m < 2 || !off) return Q;
  const double tolerance = opt.relative_tolerance() * P.rowwise().norm().maxCoeff();
  auto holds = [&](const ExactQuadric& S) {
    if (!determined(S, tolerance, opt) || reducible(S)) return false;
    double side = 0;
    return std::all_of(faces.begin(), faces.end(), [&](int f) { return face_on(mesh, f, S, opt, side, &W); });
  };
  Q = fit_tangent_quadric(P, X.topRows(m), N.topRows(m));
  Q.tolerance = tolerance;
  if (holds(Q)) return Q;
  if (!opt.cyclides) return ExactQuadric{};
  Q = fit_tangent_cyclide(P, X.topRows(m), N.topRows(m));
  Q.tolerance = tolerance;
  Q.valid = holds(Q);
  return Q;
}

/// Wedges that may take one and whose faces all lie on the tangent surface of a region of free
/// faces (tangent_region_surface) take it. Returns how many took one.
long long tangent_region_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const ExactQuadricOptions& opt,
                              std::vector<LocalFit>& fits) {
  const int nf = mesh.num_faces();
  const std::vector<const LocalFit*> held = face_exact_fits(mesh, T, W, fits, opt);
  std::vector<int> parent(nf);
  for (int f = 0; f < nf; ++f) parent[f] = f;
  std::vector<char> free(nf);
  for (int f = 0; f < nf; ++f) free[f] = !held[f] && wants_surface(mesh, W, fits, f, opt);
  for (int e = 0; e < T.num_edges(); ++e) {
    if (T.edge_faces[e].size() != 2) continue;
    const int f = T.edge_faces[e][0], g = T.edge_faces[e][1];
    if (!free[f] || !free[g]) continue;
    bool smooth = true;
    for (int s = 0; s < 2; ++s) {
      int jf = 0, jg = 0;
      while (mesh.F(f, jf) != T.E(e, s)) ++jf;
      while (mesh.F(g, jg) != T.E(e, s)) ++jg;
      smooth = smooth && W.corner_wedge(f, jf) == W.corner_wedge(g, jg);
    }
    if (smooth) parent[find_root(parent, f)] = find_root(parent, g);
  }
  std::vector<std::vector<int>> regions(nf);
  for (int f = 0; f < nf; ++f)
    if (free[f]) regions[find_root(parent, f)].push_back(f);
  std::vector<std::shared_ptr<const ExactQuadric>> surface(nf);
  tbb::parallel_for(tbb::blocked_range<int>(0, nf, 16), [&](const tbb::blocked_range<int>& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      if (regions[f].size() < 2) continue;
      ExactQuadric Q = tangent_region_surface(mesh, T, W, fits, regions[f], opt);
      if (Q.valid) surface[f] = std::make_shared<const ExactQuadric>(std::move(Q));
    }
  });
  long long taken = 0;
  for (int w = 0; w < W.num_wedges(); ++w) {
    if (!may_take(mesh, W, fits, w, opt) || W.wedge_start[w] == W.wedge_start[w + 1]) continue;
    const auto& S = surface[find_root(parent, W.wedge_faces[W.wedge_start[w]])];
    if (S && free[W.wedge_faces[W.wedge_start[w]]] && wedge_faces_on(mesh, W, w, *S, opt)) {
      fits[w] = exact_surface_fit(S, fits[w], fits[w].requested_degree);
      ++taken;
    }
  }
  return taken;
}

}  // namespace

long long tangent_exact_fits(const Mesh& mesh, const Topology& T, const Wedges& W, const ExactQuadricOptions& opt,
                             std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  long long fitted = 0;
  std::vector<std::shared_ptr<const ExactQuadric>> found(nw);
  // Nothing to be tangent to (scans, smooth meshes): no pass.
  bool changed = std::any_of(fits.begin(), fits.end(), [](const LocalFit& F) { return F.exact; });
  while (changed) {
    tbb::parallel_for(tbb::blocked_range<int>(0, nw, 64), [&](const tbb::blocked_range<int>& r) {
      for (int w = r.begin(); w < r.end(); ++w) {
        found[w].reset();
        if (!may_take(mesh, W, fits, w, opt)) continue;
        ExactQuadric Q = tangent_wedge_quadric(mesh, T, W, fits, w, opt);
        if (Q.valid) found[w] = std::make_shared<const ExactQuadric>(std::move(Q));
      }
    });
    changed = false;
    for (int w = 0; w < nw; ++w)
      if (found[w]) {
        fits[w] = exact_surface_fit(found[w], fits[w], fits[w].requested_degree);
        changed = true;
        ++fitted;
      }
    if (changed) fitted += share_exact_fits(mesh, W, opt, fits);
    if (!changed) {
      const long long region = tangent_region_fits(mesh, T, W, opt, fits);
      if (region > 0) fitted += region + share_exact_fits(mesh, W, opt, fits);
      changed = region > 0;
    }
  }
  return fitted;
}

long long share_exact_fits(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt, std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  long long shared = 0;
  std::vector<int> from(nw);
  for (bool changed = true; changed;) {
    std::fill(from.begin(), from.end(), -1);
    tbb::parallel_for(tbb::blocked_range<int>(0, nw, 256), [&](const tbb::blocked_range<int>& r) {
      for (int w = r.begin(); w < r.end(); ++w) {
        if (!may_take(mesh, W, fits, w, opt)) continue;
        for (int i = W.wedge_start[w]; i < W.wedge_start[w + 1] && from[w] < 0; ++i)
          for (int j = 0; j < 3 && from[w] < 0; ++j) {
            const int u = W.corner_wedge(W.wedge_faces[i], j);
            if (u != w && fits[u].exact && wedge_faces_on(mesh, W, w, *fits[u].surface, opt)) from[w] = u;
          }
      }
    });
    changed = false;
    for (int w = 0; w < nw; ++w)
      if (from[w] >= 0) {
        fits[w] = exact_surface_fit(fits[from[w]].surface, fits[w], fits[w].requested_degree);
        changed = true;
        ++shared;
      }
  }
  return shared;
}

long long refit_shared_surfaces(const Mesh& mesh, const Wedges& W, const ExactQuadricOptions& opt,
                                std::vector<LocalFit>& fits) {
  const int nw = W.num_wedges();
  auto holds = [&](int w) { return fits[w].exact && !fits[w].apex && fits[w].surface; };
  // Wedges join where they hold one surface, or two that both hold a face at both: the pieces of
  // one CAD face (a merge of two, as at a tangent junction, fits neither and is left as it was).
  std::vector<int> parent(nw);
  for (int w = 0; w < nw; ++w) parent[w] = w;
  auto join = [&](int a, int b) {
    a = find_root(parent, a), b = find_root(parent, b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int j = 0; j < 3; ++j)
      for (int k = j + 1; k < 3; ++k) {
        const int a = W.corner_wedge(f, j), b = W.corner_wedge(f, k);
        if (a == b || !holds(a) || !holds(b)) continue;
        double side_a = 0, side_b = 0;
        if (fits[a].surface == fits[b].surface ||
            (face_on(mesh, f, *fits[a].surface, opt, side_a, &W) && face_on(mesh, f, *fits[b].surface, opt, side_b, &W)))
          join(a, b);
      }
  // Groups in order of their first wedge (deterministic).
  std::vector<std::vector<int>> groups;
  std::vector<int> group_of(nw, -1);
  for (int w = 0; w < nw; ++w) {
    if (!holds(w)) continue;
    int& g = group_of[find_root(parent, w)];
    if (g < 0) g = static_cast<int>(groups.size()), groups.emplace_back();
    groups[g].push_back(w);
  }
  std::erase_if(groups, [](const std::vector<int>& g) { return g.size() < 2; });
  std::vector<std::shared_ptr<const ExactQuadric>> refit(groups.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t g = r.begin(); g < r.end(); ++g) {
      const ExactQuadric& Q = *fits[groups[g][0]].surface;
      std::vector<int> faces;
      for (int w : groups[g]) faces.insert(faces.end(), W.wedge_faces.begin() + W.wedge_start[w], W.wedge_faces.begin() + W.wedge_start[w + 1]);
      std::sort(faces.begin(), faces.end());
      faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
      const std::vector<int> verts = face_corners(mesh, faces.data(), faces.data() + faces.size());
      Eigen::MatrixXd P(verts.size(), 3);
      for (size_t i = 0; i < verts.size(); ++i) P.row(i) = mesh.V.row(verts[i]);
      ExactQuadric R = Q.cyclide() ? fit_exact_cyclide(P) : fit_exact_quadric(P, Q.plane());
      R.tolerance = opt.relative_tolerance() * P.rowwise().norm().maxCoeff();
      if (!determined(R, R.tolerance, opt) || reducible(R) || R.cyclide() != Q.cyclide() || R.plane() != Q.plane())
        continue;
      double side = 0;
      bool agree = true;
      for (size_t i = 0; i < faces.size() && agree; ++i) agree = face_agrees(mesh, faces[i], R, opt, side);
      if (agree) refit[g] = std::make_shared<const ExactQuadric>(R);
    }
  });
  long long count = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (!refit[g]) continue;
    ++count;
    for (int w : groups[g]) {
      LocalFit& F = fits[w];
      Eigen::Vector3d n = refit[g]->gradient(F.o).normalized();
      F.n = n.dot(F.n) < 0 ? Eigen::Vector3d(-n) : n;
      tangent_frame(F.n, F.t1, F.t2);
      F.surface = refit[g];
    }
  }
  return count;
}

}  // namespace hocurve
