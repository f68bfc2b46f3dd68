#include "engine/coarse/surface_distance.hpp"

#include "engine/coarse/dense_surface.hpp"
#include "engine/highorder/lagrange.hpp"
#include "engine/highorder/reference_nodes.hpp"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hocurve {

TriangleGrid build_triangle_grid(const Mesh& m, double cells_per_face) {
  TriangleGrid G;
  G.mesh = &m;
  const int nf = m.num_faces();
  if (nf == 0) return G;
  const Eigen::Vector3d lo = m.V.colwise().minCoeff().transpose(), hi = m.V.colwise().maxCoeff().transpose();
  double area = 0;
  for (int f = 0; f < nf; ++f)
  {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = m.V.row(m.F(f, 1)).transpose(),
                          c = m.V.row(m.F(f, 2)).transpose();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  const Eigen::Vector3d ext = (hi - lo).cwiseMax(1e-300);
  // Cells about the size of a few triangles, without more cells than faces allow.
  double cell = std::max(std::sqrt(area / (nf * std::max(cells_per_face, 1e-3))), 1e-12 * ext.maxCoeff());
  for (;;) {
    const Eigen::Vector3d d = (ext / cell).array().floor() + 1;
    if (d.prod() <= 8.0 * nf + 1000) break;
    cell *= 1.25;
  }
  G.lo = lo;
  G.cell = cell;
  for (int k = 0; k < 3; ++k) G.dims[k] = static_cast<int>(std::floor(ext[k] / cell)) + 1;
  const long long ncell = static_cast<long long>(G.dims[0]) * G.dims[1] * G.dims[2];
  auto cell_of = [&](const Eigen::Vector3d& x) {
    Eigen::Vector3i c;
    for (int k = 0; k < 3; ++k) c[k] = std::clamp(static_cast<int>(std::floor((x[k] - lo[k]) / cell)), 0, G.dims[k] - 1);
    return c;
  };
  auto index = [&](int i, int j, int k) { return (static_cast<long long>(k) * G.dims[1] + j) * G.dims[0] + i; };
  std::vector<int> count(ncell + 1, 0);
  auto for_cells = [&](int f, auto&& fn) {
    Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = a;
    for (int j = 1; j < 3; ++j) a = a.cwiseMin(m.V.row(m.F(f, j)).transpose()), b = b.cwiseMax(m.V.row(m.F(f, j)).transpose());
    const Eigen::Vector3i c0 = cell_of(a), c1 = cell_of(b);
    for (int k = c0[2]; k <= c1[2]; ++k)
      for (int j = c0[1]; j <= c1[1]; ++j)
        for (int i = c0[0]; i <= c1[0]; ++i) fn(index(i, j, k));
  };
  for (int f = 0; f < nf; ++f) for_cells(f, [&](long long c) { ++count[c + 1]; });
  for (long long c = 0; c < ncell; ++c) count[c + 1] += count[c];
  G.start = count;
  G.items.resize(G.start.back());
  std::vector<int> fill(G.start.begin(), G.start.end() - 1);
  for (int f = 0; f < nf; ++f) for_cells(f, [&](long long c) { G.items[fill[c]++] = f; });
  G.boxes.resize(nf);
  for (int f = 0; f < nf; ++f) {
    Eigen::Vector3d a = m.V.row(m.F(f, 0)).transpose(), b = a;
    for (int j = 1; j < 3; ++j) a = a.cwiseMin(m.V.row(m.F(f, j)).transpose()), b = b.cwiseMax(m.V.row(m.F(f, j)).transpose());
    G.boxes[f] = {a[0], a[1], a[2], b[0], b[1], b[2]};
  }
  return G;
}

namespace {
/// Squared distance from x to the box [lo, hi].
double box_distance2(const Eigen::Vector3d& x, const double* lo, const double* hi) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double d = std::max({lo[k] - x[k], 0.0, x[k] - hi[k]});
    s += d * d;
  }
  return s;
}
}  // namespace

double grid_search(const TriangleGrid& G, const Eigen::Vector3d& x, double max_r, double stop_below, int* face) {
  const Mesh& m = *G.mesh;
  Eigen::Vector3i c;
  for (int k = 0; k < 3; ++k)
    c[k] = std::clamp(static_cast<int>(std::floor((x[k] - G.lo[k]) / G.cell)), 0, G.dims[k] - 1);
  double best = std::numeric_limits<double>::infinity();
  int bf = -1;
  const int rmax = G.dims.maxCoeff();
  for (int r = 0; r <= rmax; ++r) {
    for (int k = c[2] - r; k <= c[2] + r; ++k) {
      if (k < 0 || k >= G.dims[2]) continue;
      for (int j = c[1] - r; j <= c[1] + r; ++j) {
        if (j < 0 || j >= G.dims[1]) continue;
        const bool edge_jk = std::abs(k - c[2]) == r || std::abs(j - c[1]) == r;
        for (int i = c[0] - r; i <= c[0] + r; i += (edge_jk ? 1 : std::max(1, 2 * r))) {
          if (i < 0 || i >= G.dims[0]) continue;
          const long long id = (static_cast<long long>(k) * G.dims[1] + j) * G.dims[0] + i;
          // Pruning only skips triangles that cannot come closer than `best`: the same result.
          const double clo[3] = {G.lo[0] + i * G.cell, G.lo[1] + j * G.cell, G.lo[2] + k * G.cell};
          const double chi[3] = {clo[0] + G.cell, clo[1] + G.cell, clo[2] + G.cell};
          if (box_distance2(x, clo, chi) >= best * best) continue;
          for (int t = G.start[id]; t < G.start[id + 1]; ++t) {
            const int f = G.items[t];
            if (box_distance2(x, G.boxes[f].data(), G.boxes[f].data() + 3) >= best * best) continue;
            Eigen::Vector3d bc;
            const Eigen::Vector3d q =
                closest_point_on_triangle(x, m.V.row(m.F(f, 0)).transpose(), m.V.row(m.F(f, 1)).transpose(),
                                          m.V.row(m.F(f, 2)).transpose(), bc);
            const double d = (q - x).norm();
            if (d < best) best = d, bf = f;
            if (best < stop_below) {
              if (face) *face = bf;
              return best;
            }
          }
        }
      }
    }
    // Cells beyond shell r are at least r cells away from x.
    if (best <= r * G.cell || r * G.cell > max_r) break;
  }
  if (face) *face = bf;
  return best;
}

double grid_distance(const TriangleGrid& G, const Eigen::Vector3d& x, int* face) {
  return grid_search(G, x, std::numeric_limits<double>::infinity(), -1, face);
}

bool grid_within(const TriangleGrid& G, const Eigen::Vector3d& x, double r) {
  return grid_search(G, x, r, r, nullptr) <= r;
}

Mesh tessellate(const HighOrderMesh& hm, int n, const std::vector<int>* faces) {
  const int p = hm.order;
  const int nl = (n + 1) * (n + 2) / 2;
  Eigen::MatrixXd uv(nl, 2);
  std::vector<std::vector<int>> id(n + 1, std::vector<int>(n + 1, -1));
  int r = 0;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i + j <= n; ++i) {
      uv.row(r) << double(i) / n, double(j) / n;
      id[i][j] = r++;
    }
  Mesh out;
  const int nf = faces ? static_cast<int>(faces->size()) : hm.num_faces();
  out.V.resize(static_cast<Eigen::Index>(nf) * nl, 3);
  out.F.resize(static_cast<Eigen::Index>(nf) * n * n, 3);
  for (int el = 0; el < nf; ++el) {
    const int f = faces ? (*faces)[el] : el;
    const Eigen::MatrixXd X = p >= 2 ? evaluate_triangle(element_nodes(hm, f), p, uv) : Eigen::MatrixXd();
    for (int k = 0; k < nl; ++k) {
      if (p >= 2) {
        out.V.row(static_cast<Eigen::Index>(el) * nl + k) = X.row(k);
      } else {
        const double u = uv(k, 0), v = uv(k, 1);
        out.V.row(static_cast<Eigen::Index>(el) * nl + k) =
            (1 - u - v) * hm.V.row(hm.F(f, 0)) + u * hm.V.row(hm.F(f, 1)) + v * hm.V.row(hm.F(f, 2));
      }
    }
    int t = el * n * n;
    const int base = el * nl;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i + j < n; ++i) {
        out.F.row(t++) << base + id[i][j], base + id[i + 1][j], base + id[i][j + 1];
        if (i + j + 1 < n) out.F.row(t++) << base + id[i + 1][j], base + id[i + 1][j + 1], base + id[i][j + 1];
      }
  }
  return out;
}

Eigen::MatrixXd sample_faces(const Mesh& m, int n) {
  // Each lattice point once: the used vertices, the n - 1 inner points of each edge, the faces'
  // inner points. Callers take the max (or mean) over the samples; repeats (a vertex sits in about
  // six faces) only cost queries: a third of them at n = 2.
  const int nf = m.num_faces();
  std::vector<char> used(m.num_vertices(), 0);
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<size_t>(3) * nf);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      const int a = m.F(f, j), b = m.F(f, (j + 1) % 3);
      used[a] = 1;
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const long long nu = std::count(used.begin(), used.end(), 1);
  Eigen::MatrixXd P(nu + static_cast<long long>(edges.size()) * (n - 1) + static_cast<long long>(nf) * (n - 1) * (n - 2) / 2, 3);
  Eigen::Index r = 0;
  for (int v = 0; v < m.num_vertices(); ++v)
    if (used[v]) P.row(r++) = m.V.row(v);
  for (const auto& [a, b] : edges)
    for (int i = 1; i < n; ++i) P.row(r++) = (1 - double(i) / n) * m.V.row(a) + (double(i) / n) * m.V.row(b);
  for (int f = 0; f < nf; ++f)
    for (int j = 1; j < n; ++j)
      for (int i = 1; i + j < n; ++i) {
        const double u = double(i) / n, v = double(j) / n;
        P.row(r++) = (1 - u - v) * m.V.row(m.F(f, 0)) + u * m.V.row(m.F(f, 1)) + v * m.V.row(m.F(f, 2));
      }
  return P;
}

namespace {
void one_side(const Mesh& A, const TriangleGrid& gb, int n, double& mx, double& mean) {
  const Eigen::MatrixXd P = sample_faces(A, n);
  std::vector<double> d(P.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, P.rows()), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index i = r.begin(); i < r.end(); ++i) d[i] = grid_distance(gb, P.row(i).transpose());
  });
  mx = 0, mean = 0;
  for (double x : d) mx = std::max(mx, x), mean += x;
  mean = d.empty() ? 0 : mean / d.size();
}
}  // namespace

HausdorffResult hausdorff_distance(const Mesh& A, const Mesh& B, int n) {
  HausdorffResult H;
  const TriangleGrid ga = build_triangle_grid(A), gb = build_triangle_grid(B);
  one_side(A, gb, n, H.a_to_b, H.mean_a_to_b);
  one_side(B, ga, n, H.b_to_a, H.mean_b_to_a);
  return H;
}

std::vector<double> element_deviation(const HighOrderMesh& hm, const Mesh& dense, int n, int dense_n) {
  const Mesh T = tessellate(hm, n);
  const TriangleGrid gd = build_triangle_grid(dense), gt = build_triangle_grid(T);
  const Eigen::MatrixXd Pd = sample_faces(dense, dense_n);
  const int per_el_points = (n + 1) * (n + 2) / 2, per_el_tris = n * n;
  std::vector<double> dev(hm.num_faces(), 0.0);
  // Element -> dense: each element's lattice points (the tessellation's vertices).
  tbb::parallel_for(0, hm.num_faces(), [&](int f) {
    double mx = 0;
    for (Eigen::Index i = static_cast<Eigen::Index>(f) * per_el_points; i < static_cast<Eigen::Index>(f + 1) * per_el_points; ++i)
      mx = std::max(mx, grid_distance(gd, T.V.row(i).transpose()));
    dev[f] = mx;
  });
  // Dense -> elements: a dense sample counts for the element its closest point lies in.
  std::vector<double> d(Pd.rows());
  std::vector<int> owner(Pd.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, Pd.rows()), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
      int t = -1;
      d[i] = grid_distance(gt, Pd.row(i).transpose(), &t);
      owner[i] = t < 0 ? -1 : t / per_el_tris;
    }
  });
  for (Eigen::Index i = 0; i < Pd.rows(); ++i)
    if (owner[i] >= 0) dev[owner[i]] = std::max(dev[owner[i]], d[i]);
  return dev;
}

}  // namespace hocurve
