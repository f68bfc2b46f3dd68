// Reference nodes of Lagrange triangles and tets in Gmsh order, equispaced or Lobatto
// (Gauss-Lobatto-Legendre edges, Warburton's warp & blend inside).
#include "engine/highorder/reference_nodes.hpp"

#include "engine/core/error.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace hocurve {

namespace {

constexpr int kMaxOrder = 10;

void check_order(int p, const char* what) {
  if (p < 1 || p > kMaxOrder)
    throw UsageError(std::string(what) + ": order " + std::to_string(p) + " out of range 1.." +
                     std::to_string(kMaxOrder));
}

using Tri = std::array<int, 2>;
using Tet = std::array<int, 3>;

// Gmsh's recursive triangle rule (as Gmsh 4.8 orders its nodes): vertices, edges 0->1, 1->2, 2->0 each walked
// from its first vertex, then the order-(p-3) triangle shifted by (1,1). p = 0 is one point.
std::vector<Tri> tri_lattice_rec(int p) {
  if (p == 0) return {Tri{0, 0}};
  const Tri V[3] = {{0, 0}, {p, 0}, {0, p}};
  std::vector<Tri> out(V, V + 3);
  const int edges[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (auto& ab : edges)
    for (int k = 1; k < p; ++k) {
      Tri t;
      for (int d = 0; d < 2; ++d) t[d] = V[ab[0]][d] + (V[ab[1]][d] - V[ab[0]][d]) * k / p;
      out.push_back(t);
    }
  if (p >= 3)
    for (const Tri& t : tri_lattice_rec(p - 3)) out.push_back({t[0] + 1, t[1] + 1});
  return out;
}

// Gmsh's recursive tet rule: vertices, edges 0-1,1-2,2-0,3-0,3-2,3-1, faces (0,2,1),
// (0,1,3), (0,3,2), (3,1,2) each with an order-(p-3) triangle, then the order-(p-4) tet.
std::vector<Tet> tet_lattice_rec(int p) {
  if (p == 0) return {Tet{0, 0, 0}};
  const Tet V[4] = {{0, 0, 0}, {p, 0, 0}, {0, p, 0}, {0, 0, p}};
  std::vector<Tet> out(V, V + 4);
  const int edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}};
  for (auto& ab : edges)
    for (int k = 1; k < p; ++k) {
      Tet t;
      for (int d = 0; d < 3; ++d) t[d] = V[ab[0]][d] + (V[ab[1]][d] - V[ab[0]][d]) * k / p;
      out.push_back(t);
    }
  if (p >= 3) {
    const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {3, 1, 2}};
    const std::vector<Tri> sub = tri_lattice_rec(p - 3);
    for (auto& f : faces)
      for (const Tri& t : sub) {
        const int l1 = t[0] + 1, l2 = t[1] + 1, l0 = p - l1 - l2;
        Tet x;
        for (int d = 0; d < 3; ++d) x[d] = (l0 * V[f[0]][d] + l1 * V[f[1]][d] + l2 * V[f[2]][d]) / p;
        out.push_back(x);
      }
  }
  if (p >= 4)
    for (const Tet& t : tet_lattice_rec(p - 4)) out.push_back({t[0] + 1, t[1] + 1, t[2] + 1});
  return out;
}

// Legendre P_n(x) and its derivative by the three-term recurrence.
void legendre(int n, double x, double& P, double& dP) {
  double p0 = 1, p1 = x;
  if (n == 0) {
    P = 1;
    dP = 0;
    return;
  }
  for (int k = 2; k <= n; ++k) {
    const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  P = p1;
  // P'_n = n (x P_n - P_{n-1}) / (x^2 - 1), valid in the open interval (GLL interior roots).
  dP = n * (x * p1 - p0) / (x * x - 1);
}

// The p+1 Gauss-Lobatto-Legendre points on [-1, 1], ascending: the ends and the roots of
// P'_p, found by Newton from the Chebyshev-Lobatto points (P'' from Legendre's equation).
// Exactly antisymmetric by construction.
std::vector<double> gll_points(int p) {
  std::vector<double> x(p + 1);
  x[0] = -1;
  x[p] = 1;
  for (int k = 1; k < p; ++k) {
    if (2 * k > p) {
      x[k] = -x[p - k];
      continue;
    }
    if (2 * k == p) {
      x[k] = 0;
      continue;
    }
    double r = -std::cos(M_PI * k / p);
    for (int it = 0; it < 100; ++it) {
      double P, dP;
      legendre(p, r, P, dP);
      const double d2P = (2 * r * dP - p * (p + 1) * P) / (1 - r * r);
      const double step = dP / d2P;
      r -= step;
      if (std::abs(step) < 1e-16) break;
    }
    x[k] = r;
  }
  return x;
}

// Warburton's optimised blend parameters alpha(p) for the triangle (Hesthaven & Warburton,
// "Nodal Discontinuous Galerkin Methods", 2008, Table 6.1), p = 1..15.
constexpr double kAlphaOpt[16] = {0,      0.0000, 0.0000, 1.4152, 0.1001, 0.2751, 0.9800, 1.0999,
                                  1.2832, 1.3648, 1.4773, 1.4959, 1.5743, 1.5770, 1.6223, 1.6258};

// 1D warp at r in [-1, 1]: the equispaced-to-GLL displacement interpolated through the
// equispaced points, divided by (1 - r^2) (the edge blend multiplies it back).
double warp_factor(int p, const std::vector<double>& gll, double r) {
  double w = 0;
  for (int i = 0; i <= p; ++i) {
    const double ri = -1 + 2.0 * i / p;
    double li = 1;
    for (int j = 0; j <= p; ++j)
      if (j != i) li *= (r - (-1 + 2.0 * j / p)) / (ri - (-1 + 2.0 * j / p));
    w += li * (gll[i] - ri);
  }
  if (std::abs(r) < 1 - 1e-10) w /= 1 - r * r;
  return w;
}


// Warburton's blend parameters for the tetrahedron's interior, p = 1..15 (same source).
constexpr double kAlphaOpt3D[16] = {0,      0,      0,      0,      0.1002, 1.1332, 1.5608, 1.3413,
                                    1.2577, 1.1603, 1.10153, 0.6080, 0.4523, 0.8856, 0.8717, 0.9655};

struct LobattoTables {
  int p = 0;
  std::vector<double> gll;  // GLL points on [-1, 1]
  std::vector<double> line; // the same on [0, 1], exactly symmetric
  double alpha = 0;         // 2D blend parameter
};

LobattoTables lobatto_tables(int p) {
  LobattoTables t;
  t.p = p;
  t.gll = gll_points(p);
  t.line.resize(p + 1);
  for (int k = 0; k <= p; ++k) t.line[k] = 0.5 * (1 + t.gll[k]);
  for (int k = 0; 2 * k < p; ++k) t.line[p - k] = 1 - t.line[k];
  t.alpha = kAlphaOpt[p];
  return t;
}

// Warp & blend shift of a triangle point with (possibly unnormalised) barycentrics lam, as a
// change of barycentrics: each edge (a, b) opposite c moves the point along b - a by half
// its blended 1D warp. Affine-covariant, so it is computed without any physical frame.
void triangle_warp_shift(const LobattoTables& t, double alpha, const double lam[3], double shift[3]) {
  shift[0] = shift[1] = shift[2] = 0;
  for (int c = 0; c < 3; ++c) {
    const int a = (c + 1) % 3, b = (c + 2) % 3;
    const double w = 4 * lam[a] * lam[b] * warp_factor(t.p, t.gll, lam[b] - lam[a]) *
                     (1 + (alpha * lam[c]) * (alpha * lam[c]));
    shift[b] += 0.5 * w;
    shift[a] -= 0.5 * w;
  }
}

// Barycentric coordinates of the Lobatto triangle node with lattice barycentric indices li
// (sum p). Edge nodes are exactly the 1D points, so neighbouring elements agree to the bit
// (up to the a + t (b - a) rounding of the caller).
void lobatto_triangle_barycentric(const LobattoTables& t, const int li[3], double lam[3]) {
  for (int c = 0; c < 3; ++c)
    if (li[c] == 0) {
      const int a = (c + 1) % 3, b = (c + 2) % 3;
      lam[c] = 0;
      lam[b] = t.line[li[b]];
      lam[a] = 1 - lam[b];
      return;
    }
  double l[3], shift[3];
  for (int c = 0; c < 3; ++c) l[c] = double(li[c]) / t.p;
  triangle_warp_shift(t, t.alpha, l, shift);
  for (int c = 0; c < 3; ++c) lam[c] = l[c] + shift[c];
}

}  // namespace

const char* to_string(NodeDistribution d) {
  return d == NodeDistribution::Lobatto ? "lobatto" : "equispaced";
}

NodeDistribution parse_node_distribution(const std::string& s) {
  if (s == "equispaced") return NodeDistribution::Equispaced;
  if (s == "lobatto") return NodeDistribution::Lobatto;
  throw UsageError("unknown node distribution '" + s + "' (expected equispaced or lobatto)");
}

int gmsh_triangle_type(int p) {
  check_order(p, "gmsh_triangle_type");
  static constexpr int types[kMaxOrder + 1] = {0, 2, 9, 21, 23, 25, 42, 43, 44, 45, 46};
  return types[p];
}

int gmsh_tet_type(int p) {
  check_order(p, "gmsh_tet_type");
  static constexpr int types[kMaxOrder + 1] = {0, 4, 11, 29, 30, 31, 71, 72, 73, 74, 75};
  return types[p];
}

int triangle_node_count(int p) { return (p + 1) * (p + 2) / 2; }
int tet_node_count(int p) { return (p + 1) * (p + 2) * (p + 3) / 6; }

Eigen::MatrixXi triangle_lattice(int p) {
  check_order(p, "triangle_lattice");
  const std::vector<Tri> L = tri_lattice_rec(p);
  Eigen::MatrixXi out(static_cast<Eigen::Index>(L.size()), 2);
  for (size_t k = 0; k < L.size(); ++k) out.row(k) << L[k][0], L[k][1];
  return out;
}

Eigen::MatrixXi tet_lattice(int p) {
  check_order(p, "tet_lattice");
  const std::vector<Tet> L = tet_lattice_rec(p);
  Eigen::MatrixXi out(static_cast<Eigen::Index>(L.size()), 3);
  for (size_t k = 0; k < L.size(); ++k) out.row(k) << L[k][0], L[k][1], L[k][2];
  return out;
}

Eigen::VectorXd line_reference_nodes(int p, NodeDistribution d) {
  check_order(p, "line_reference_nodes");
  Eigen::VectorXd t(p + 1);
  if (d == NodeDistribution::Lobatto) {
    const std::vector<double> x = gll_points(p);
    for (int k = 0; k <= p; ++k) t[k] = 0.5 * (1 + x[k]);
    // Keep the map exactly symmetric: t[p-k] = 1 - t[k].
    for (int k = 0; 2 * k < p; ++k) t[p - k] = 1 - t[k];
  } else {
    for (int k = 0; k <= p; ++k) t[k] = static_cast<double>(k) / p;
  }
  return t;
}

Eigen::MatrixXd triangle_reference_nodes(int p, NodeDistribution d) {
  const Eigen::MatrixXi L = triangle_lattice(p);
  Eigen::MatrixXd uv(L.rows(), 2);
  if (d == NodeDistribution::Equispaced || p <= 2) {
    for (Eigen::Index k = 0; k < L.rows(); ++k) uv.row(k) << double(L(k, 0)) / p, double(L(k, 1)) / p;
    return uv;
  }
  const LobattoTables tab = lobatto_tables(p);
  for (Eigen::Index k = 0; k < L.rows(); ++k) {
    const int li[3] = {p - L(k, 0) - L(k, 1), L(k, 0), L(k, 1)};
    double lam[3];
    lobatto_triangle_barycentric(tab, li, lam);
    uv.row(k) << lam[1], lam[2];
  }
  return uv;
}

Eigen::MatrixXd tet_reference_nodes(int p, NodeDistribution d) {
  const Eigen::MatrixXi L = tet_lattice(p);
  Eigen::MatrixXd uvw(L.rows(), 3);
  if (d == NodeDistribution::Equispaced || p <= 2) {
    for (Eigen::Index k = 0; k < L.rows(); ++k)
      uvw.row(k) << double(L(k, 0)) / p, double(L(k, 1)) / p, double(L(k, 2)) / p;
    return uvw;
  }
  const LobattoTables tab = lobatto_tables(p);
  const double alpha3 = kAlphaOpt3D[p];
  for (Eigen::Index k = 0; k < L.rows(); ++k) {
    const int li[4] = {p - L(k, 0) - L(k, 1) - L(k, 2), L(k, 0), L(k, 1), L(k, 2)};
    double lam[4] = {0, 0, 0, 0};
    int zero = -1;
    for (int c = 0; c < 4; ++c)
      if (li[c] == 0) zero = c;
    if (zero >= 0) {
      // On a face: exactly the Lobatto triangle's node, so tets and surface triangles conform.
      int face[3], n = 0;
      for (int c = 0; c < 4; ++c)
        if (c != zero) face[n++] = c;
      const int fl[3] = {li[face[0]], li[face[1]], li[face[2]]};
      double fb[3];
      lobatto_triangle_barycentric(tab, fl, fb);
      for (int c = 0; c < 3; ++c) lam[face[c]] = fb[c];
    } else {
      // Interior: equispaced point plus every face's 2D warp, blended into the volume
      // (Warburton 2006, with the face's unnormalised barycentrics).
      double L4[4];
      for (int c = 0; c < 4; ++c) L4[c] = double(li[c]) / p;
      for (int c = 0; c < 4; ++c) lam[c] = L4[c];
      for (int a = 0; a < 4; ++a) {
        int face[3], n = 0;
        for (int c = 0; c < 4; ++c)
          if (c != a) face[n++] = c;
        const double fb[3] = {L4[face[0]], L4[face[1]], L4[face[2]]};
        double shift[3];
        triangle_warp_shift(tab, alpha3, fb, shift);
        const double La = L4[a], Lb = fb[0], Lc = fb[1], Ld = fb[2];
        const double blend = (1 + (alpha3 * La) * (alpha3 * La)) * Lb * Lc * Ld /
                             ((Lb + 0.5 * La) * (Lc + 0.5 * La) * (Ld + 0.5 * La));
        for (int c = 0; c < 3; ++c) lam[face[c]] += blend * shift[c];
      }
    }
    uvw.row(k) << lam[1], lam[2], lam[3];
  }
  return uvw;
}

}  // namespace hocurve
