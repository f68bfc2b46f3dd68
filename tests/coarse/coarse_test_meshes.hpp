// Small analytic meshes for the coarse-lifting tests and benchmark (local generators, so the
// tests do not depend on other areas' sources).
#pragma once
#include "engine/core/mesh.hpp"

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <vector>

namespace hocurve::coarse_test {

/// Unit icosphere, 20 * 4^s faces, counter-clockwise from outside.
inline Mesh icosphere(int s) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Eigen::Vector3d> V = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : V) v.normalize();
  std::vector<std::array<int, 3>> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int it = 0; it < s; ++it) {
    std::map<std::pair<int, int>, int> mid;
    auto m = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto f = mid.find(key);
      if (f != mid.end()) return f->second;
      V.push_back((V[a] + V[b]).normalized());
      return mid[key] = static_cast<int>(V.size() - 1);
    };
    std::vector<std::array<int, 3>> G;
    for (auto [a, b, c] : F) {
      const int ab = m(a, b), bc = m(b, c), ca = m(c, a);
      G.push_back({a, ab, ca}), G.push_back({b, bc, ab}), G.push_back({c, ca, bc}), G.push_back({ab, bc, ca});
    }
    F.swap(G);
  }
  Mesh M;
  M.V.resize(V.size(), 3);
  for (size_t i = 0; i < V.size(); ++i) M.V.row(i) = V[i].transpose();
  M.F.resize(F.size(), 3);
  for (size_t i = 0; i < F.size(); ++i) M.F.row(i) << F[i][0], F[i][1], F[i][2];
  return M;
}

/// Torus around z (radii R > r), nu x nv quads split in two, counter-clockwise from outside.
inline Mesh torus(int nu, int nv, double R, double r) {
  Mesh M;
  M.V.resize(nu * nv, 3);
  M.F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * i / nu, v = 2 * std::numbers::pi * j / nv;
      M.V.row(i * nv + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  auto id = [&](int i, int j) { return ((i + nu) % nu) * nv + (j + nv) % nv; };
  int f = 0;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      M.F.row(f++) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
      M.F.row(f++) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
    }
  return M;
}

/// Cube [-1,1]^3 with an n x n grid on each side, outward oriented; entity = side (1..6).
inline Mesh cube(int n) {
  std::map<std::array<int, 3>, int> index;
  std::vector<Eigen::Vector3d> V;
  auto vid = [&](std::array<int, 3> g) {
    auto it = index.find(g);
    if (it != index.end()) return it->second;
    V.push_back(Eigen::Vector3d(g[0], g[1], g[2]) * (2.0 / n) - Eigen::Vector3d::Ones());
    return index[g] = static_cast<int>(V.size() - 1);
  };
  std::vector<std::array<int, 3>> F;
  std::vector<int> ent;
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      const int u = (d + 1) % 3, w = (d + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto g = [&](int a, int b) {
            std::array<int, 3> x{};
            x[d] = side * n, x[u] = a, x[w] = b;
            return vid(x);
          };
          std::array<int, 3> t1{g(i, j), g(i + 1, j), g(i + 1, j + 1)}, t2{g(i, j), g(i + 1, j + 1), g(i, j + 1)};
          if (side == 0) std::swap(t1[1], t1[2]), std::swap(t2[1], t2[2]);
          F.push_back(t1), F.push_back(t2);
          ent.push_back(1 + 2 * d + side), ent.push_back(1 + 2 * d + side);
        }
    }
  Mesh M;
  M.V.resize(V.size(), 3);
  for (size_t i = 0; i < V.size(); ++i) M.V.row(i) = V[i].transpose();
  M.F.resize(F.size(), 3);
  M.face_entity.resize(F.size());
  for (size_t i = 0; i < F.size(); ++i) {
    M.F.row(i) << F[i][0], F[i][1], F[i][2];
    M.face_entity[i] = ent[i];
  }
  return M;
}

/// The faces of m whose centroid passes keep, with their vertices renumbered in first-use order
/// (an open surface cut out of a closed one).
inline Mesh keep_faces(const Mesh& m, const std::function<bool(const Eigen::Vector3d&)>& keep) {
  std::vector<int> faces, vmap(m.num_vertices(), -1);
  for (int f = 0; f < m.num_faces(); ++f) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) c += m.V.row(m.F(f, j)).transpose() / 3;
    if (keep(c)) faces.push_back(f);
  }
  Mesh out;
  out.F.resize(static_cast<int>(faces.size()), 3);
  int nv = 0;
  for (size_t i = 0; i < faces.size(); ++i)
    for (int j = 0; j < 3; ++j) {
      int& v = vmap[m.F(faces[i], j)];
      if (v < 0) v = nv++;
      out.F(static_cast<int>(i), j) = v;
    }
  out.V.resize(nv, 3);
  for (int v = 0; v < m.num_vertices(); ++v)
    if (vmap[v] >= 0) out.V.row(vmap[v]) = m.V.row(v);
  return out;
}

}  // namespace hocurve::coarse_test
