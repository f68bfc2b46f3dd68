#include "engine/curving/test_meshes.hpp"

#include "engine/core/error.hpp"
#include "engine/curving/support_points.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <vector>

namespace hocurve {

namespace {

using Vec3 = Eigen::Vector3d;

Mesh from_lists(const std::vector<Vec3>& V, const std::vector<std::array<int, 3>>& F,
                const std::vector<int>& entity = {}) {
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i)
    for (int j = 0; j < 3; ++j) m.F(static_cast<Eigen::Index>(i), j) = F[i][j];
  if (!entity.empty()) {
    m.face_entity.resize(static_cast<Eigen::Index>(entity.size()));
    for (size_t i = 0; i < entity.size(); ++i) m.face_entity[static_cast<Eigen::Index>(i)] = entity[i];
  }
  return m;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw InputError("test_meshes", what);
}

}  // namespace

Mesh icosphere(int subdivisions) {
  require(subdivisions >= 0 && subdivisions <= 9, "icosphere: subdivisions must be in 0..9");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> V = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : V) v.normalize();
  std::vector<std::array<int, 3>> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      const int id = static_cast<int>(V.size()) - 1;
      mid.emplace(key, id);
      return id;
    };
    std::vector<std::array<int, 3>> G;
    G.reserve(4 * F.size());
    for (const auto& f : F) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      G.push_back({f[0], a, c});
      G.push_back({f[1], b, a});
      G.push_back({f[2], c, b});
      G.push_back({a, b, c});
    }
    F.swap(G);
  }
  return from_lists(V, F);
}

Mesh uv_sphere(int nlat, int nlon) {
  require(nlat >= 2 && nlon >= 3, "uv_sphere: needs nlat >= 2 and nlon >= 3");
  const double pi = std::numbers::pi;
  std::vector<Vec3> V;
  V.push_back({0, 0, 1});
  for (int i = 1; i < nlat; ++i) {
    const double th = pi * i / nlat;
    // sin/cos of exact multiples: put the equator ring exactly at z = 0.
    const double z = (2 * i == nlat) ? 0.0 : std::cos(th), s = (2 * i == nlat) ? 1.0 : std::sin(th);
    for (int j = 0; j < nlon; ++j) {
      const double ph = 2 * pi * j / nlon;
      V.push_back({s * std::cos(ph), s * std::sin(ph), z});
    }
  }
  V.push_back({0, 0, -1});
  const int south = static_cast<int>(V.size()) - 1;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * nlon + (j % nlon); };
  std::vector<std::array<int, 3>> F;
  std::vector<int> ent;
  // Band b lies between rings b and b+1 (ring 0 = north pole, ring nlat = south pole).
  for (int b = 0; b < nlat; ++b) {
    const int e = (2 * b < nlat) ? 1 : 2;
    for (int j = 0; j < nlon; ++j) {
      if (b == 0) {
        F.push_back({0, ring(1, j), ring(1, j + 1)});
        ent.push_back(e);
      } else if (b == nlat - 1) {
        F.push_back({ring(b, j), south, ring(b, j + 1)});
        ent.push_back(e);
      } else {
        F.push_back({ring(b, j), ring(b + 1, j), ring(b + 1, j + 1)});
        F.push_back({ring(b, j), ring(b + 1, j + 1), ring(b, j + 1)});
        ent.push_back(e), ent.push_back(e);
      }
    }
  }
  return from_lists(V, F, ent);
}

Mesh torus_grid(int n_major, int n_minor, double R, double r) {
  require(n_major >= 3 && n_minor >= 3, "torus_grid: needs n_major >= 3 and n_minor >= 3");
  require(R > r && r > 0, "torus_grid: needs R > r > 0");
  const double pi = std::numbers::pi;
  std::vector<Vec3> V;
  for (int i = 0; i < n_major; ++i)
    for (int j = 0; j < n_minor; ++j) {
      const double u = 2 * pi * i / n_major, v = 2 * pi * j / n_minor;
      V.push_back({(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  auto id = [&](int i, int j) { return (i % n_major) * n_minor + (j % n_minor); };
  std::vector<std::array<int, 3>> F;
  for (int i = 0; i < n_major; ++i)
    for (int j = 0; j < n_minor; ++j) {
      // u grows counter-clockwise around z, v around the tube: (du x dv) points outward.
      F.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      F.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return from_lists(V, F);
}

Mesh ellipsoid_mesh(int subdivisions, double a, double b, double c) {
  require(a > 0 && b > 0 && c > 0, "ellipsoid_mesh: semi-axes must be positive");
  Mesh m = icosphere(subdivisions);
  for (int i = 0; i < m.num_vertices(); ++i) {
    Vec3 p(a * m.V(i, 0), b * m.V(i, 1), c * m.V(i, 2));
    // Radial rescale removes the rounding of the unit-sphere vertices.
    const double q = std::sqrt(p.x() * p.x() / (a * a) + p.y() * p.y() / (b * b) + p.z() * p.z() / (c * c));
    m.V.row(i) = (p / q).transpose();
  }
  return m;
}

Mesh capped_cylinder(int n_around, int n_height, double radius, double height) {
  require(n_around >= 3 && n_height >= 1, "capped_cylinder: needs n_around >= 3 and n_height >= 1");
  require(radius > 0 && height > 0, "capped_cylinder: radius and height must be positive");
  const double pi = std::numbers::pi;
  std::vector<Vec3> V;
  for (int k = 0; k <= n_height; ++k) {
    const double z = -height / 2 + height * k / n_height;
    for (int j = 0; j < n_around; ++j) {
      const double ph = 2 * pi * j / n_around;
      V.push_back({radius * std::cos(ph), radius * std::sin(ph), z});
    }
  }
  const int bottom = static_cast<int>(V.size());
  V.push_back({0, 0, -height / 2});
  const int top = bottom + 1;
  V.push_back({0, 0, height / 2});
  auto id = [&](int k, int j) { return k * n_around + (j % n_around); };
  std::vector<std::array<int, 3>> F;
  std::vector<int> ent;
  for (int k = 0; k < n_height; ++k)
    for (int j = 0; j < n_around; ++j) {
      F.push_back({id(k, j), id(k, j + 1), id(k + 1, j + 1)});
      F.push_back({id(k, j), id(k + 1, j + 1), id(k + 1, j)});
      ent.push_back(1), ent.push_back(1);
    }
  for (int j = 0; j < n_around; ++j) {
    F.push_back({bottom, id(0, j + 1), id(0, j)});
    ent.push_back(2);
    F.push_back({top, id(n_height, j), id(n_height, j + 1)});
    ent.push_back(3);
  }
  return from_lists(V, F, ent);
}

Mesh capped_cylinder_cad(int n_around, double radius, double height) {
  return capped_cylinder(n_around, 1, radius, height);
}

Mesh cone_mesh(int n_rings, int n_around, double radius, double height) {
  require(n_rings >= 1 && n_around >= 3, "cone_mesh: needs n_rings >= 1 and n_around >= 3");
  require(radius > 0 && height > 0, "cone_mesh: radius and height must be positive");
  std::vector<Vec3> V{{0, 0, height}};
  for (int k = 1; k <= n_rings; ++k) {
    const double t = static_cast<double>(k) / n_rings;
    for (int j = 0; j < n_around; ++j) {
      const double ph = 2 * std::numbers::pi * j / n_around;
      V.push_back({t * radius * std::cos(ph), t * radius * std::sin(ph), height * (1 - t)});
    }
  }
  const int centre = static_cast<int>(V.size());
  V.push_back({0, 0, 0});
  auto id = [&](int k, int j) { return 1 + (k - 1) * n_around + (j % n_around); };
  std::vector<std::array<int, 3>> F;
  std::vector<int> ent;
  for (int j = 0; j < n_around; ++j) F.push_back({0, id(1, j), id(1, j + 1)}), ent.push_back(1);
  for (int k = 1; k < n_rings; ++k)
    for (int j = 0; j < n_around; ++j) {
      F.push_back({id(k, j), id(k + 1, j), id(k + 1, j + 1)});
      F.push_back({id(k, j), id(k + 1, j + 1), id(k, j + 1)});
      ent.push_back(1), ent.push_back(1);
    }
  for (int j = 0; j < n_around; ++j) F.push_back({centre, id(n_rings, j + 1), id(n_rings, j)}), ent.push_back(2);
  return from_lists(V, F, ent);
}

void jitter_on_surface(Mesh& mesh, double amount, std::uint64_t seed, const Projector& project) {
  const int nv = mesh.num_vertices();
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(nv), cnt = Eigen::VectorXd::Zero(nv);
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const int a = mesh.F(f, j), b = mesh.F(f, (j + 1) % 3);
      const double l = (mesh.V.row(a) - mesh.V.row(b)).norm();
      sum[a] += l, sum[b] += l, cnt[a] += 1, cnt[b] += 1;
    }
  for (int v = 0; v < nv; ++v) {
    if (cnt[v] == 0) continue;
    const double h = sum[v] / cnt[v];
    // Uniform direction in the unit ball by rejection, from a counter-based stream.
    Vec3 d;
    for (std::uint64_t k = 0;; ++k) {
      d = Vec3(2 * counter_uniform(seed, v, 3 * k) - 1, 2 * counter_uniform(seed, v, 3 * k + 1) - 1,
               2 * counter_uniform(seed, v, 3 * k + 2) - 1);
      if (d.squaredNorm() <= 1.0 || k > 64) break;
    }
    const Vec3 p = mesh.V.row(v).transpose() + amount * h * d;
    mesh.V.row(v) = project(p).transpose();
  }
}

// --- distances --------------------------------------------------------------------------------

double sphere_distance(const Vec3& p) { return p.norm() - 1.0; }

Vec3 sphere_closest(const Vec3& p) {
  const double n = p.norm();
  return n > 0 ? Vec3(p / n) : Vec3(0, 0, 1);
}

namespace {
/// Closest point of the torus's centre circle to p, and the unit direction from it to p.
void torus_frame(const Vec3& p, double R, Vec3& centre, Vec3& dir) {
  const double rho = std::hypot(p.x(), p.y());
  const Vec3 radial = rho > 0 ? Vec3(p.x() / rho, p.y() / rho, 0) : Vec3(1, 0, 0);
  centre = R * radial;
  const Vec3 d = p - centre;
  const double n = d.norm();
  dir = n > 0 ? Vec3(d / n) : radial;
}
}  // namespace

double torus_distance(const Vec3& p, double R, double r) {
  return std::hypot(std::hypot(p.x(), p.y()) - R, p.z()) - r;
}

Vec3 torus_closest(const Vec3& p, double R, double r) {
  Vec3 c, d;
  torus_frame(p, R, c, d);
  return c + r * d;
}

namespace {
/// Closest point x on the axis-aligned ellipsoid with semi-axes e (sorted descending, n = 1..3)
/// to y (all components >= 0). Cases follow the geometry of the Lagrange condition
/// x_i = e_i^2 y_i / (t + e_i^2): zero components reduce the dimension, and when the smallest
/// axis' component is zero the closest point may lie off the y plane (medial axis).
void ellipsoid_closest_sorted(const double* e, const double* y, double* x, int n) {
  const int m = n - 1;
  if (n == 1) {
    x[0] = e[0];
    return;
  }
  if (y[m] > 0) {
    for (int i = 0; i < m; ++i)
      if (y[i] == 0) {
        // x_i = 0 there; solve in the remaining axes (still sorted).
        double es[3], ys[3], xs[3];
        int k = 0;
        for (int j = 0; j < n; ++j)
          if (j != i) es[k] = e[j], ys[k] = y[j], ++k;
        ellipsoid_closest_sorted(es, ys, xs, n - 1);
        k = 0;
        for (int j = 0; j < n; ++j) x[j] = (j == i) ? 0.0 : xs[k++];
        return;
      }
    // F(t) = sum (e_i y_i / (t + e_i^2))^2 - 1 is convex and decreasing on t > -e_m^2:
    // Newton from the left end of the bracket (F >= 0) climbs monotonically to the root.
    auto F = [&](double t, double& dF) {
      double f = -1.0;
      dF = 0.0;
      for (int i = 0; i < n; ++i) {
        const double q = e[i] * y[i] / (t + e[i] * e[i]);
        f += q * q;
        dF += -2.0 * q * q / (t + e[i] * e[i]);
      }
      return f;
    };
    double s2 = 0;
    for (int i = 0; i < n; ++i) s2 += e[i] * e[i] * y[i] * y[i];
    double lo = -e[m] * e[m] + e[m] * y[m], hi = -e[m] * e[m] + std::sqrt(s2);
    double t = lo;
    for (int it = 0; it < 200; ++it) {
      double dF;
      const double f = F(t, dF);
      if (f == 0.0) break;
      if (f > 0) lo = std::max(lo, t); else hi = std::min(hi, t);
      double tn = (dF < 0) ? t - f / dF : 0.5 * (lo + hi);
      if (!(tn > lo && tn < hi)) tn = 0.5 * (lo + hi);  // safeguard: stay inside the bracket
      if (std::abs(tn - t) <= 1e-17 * std::max(1.0, std::abs(t))) {
        t = tn;
        break;
      }
      t = tn;
    }
    for (int i = 0; i < n; ++i) x[i] = e[i] * e[i] * y[i] / (t + e[i] * e[i]);
    return;
  }
  // y_m == 0: interior medial case where x_m > 0.
  double xde[3], sum = 0;
  bool inside = true;
  for (int i = 0; i < m; ++i) {
    const double num = e[i] * y[i], den = e[i] * e[i] - e[m] * e[m];
    if (!(num < den)) {
      inside = false;
      break;
    }
    xde[i] = num / den;
    sum += xde[i] * xde[i];
  }
  if (inside && sum < 1) {
    for (int i = 0; i < m; ++i) x[i] = e[i] * xde[i];
    x[m] = e[m] * std::sqrt(1 - sum);
    return;
  }
  x[m] = 0;
  ellipsoid_closest_sorted(e, y, x, n - 1);
}
}  // namespace

Vec3 ellipsoid_closest(const Vec3& p, double a, double b, double c) {
  const double ax[3] = {a, b, c};
  std::array<int, 3> ord = {0, 1, 2};
  std::stable_sort(ord.begin(), ord.end(), [&](int i, int j) { return ax[i] > ax[j]; });
  double e[3], y[3], x[3];
  for (int k = 0; k < 3; ++k) e[k] = ax[ord[k]], y[k] = std::abs(p[ord[k]]);
  ellipsoid_closest_sorted(e, y, x, 3);
  Vec3 out;
  for (int k = 0; k < 3; ++k) out[ord[k]] = std::copysign(x[k], p[ord[k]]);
  return out;
}

double ellipsoid_distance(const Vec3& p, double a, double b, double c) {
  const double d = (p - ellipsoid_closest(p, a, b, c)).norm();
  const double q = p.x() * p.x() / (a * a) + p.y() * p.y() / (b * b) + p.z() * p.z() / (c * c);
  return q < 1 ? -d : d;
}

Vec3 capped_cylinder_closest(const Vec3& p, double radius, double height) {
  const double h = height / 2, rho = std::hypot(p.x(), p.y());
  const Vec3 radial = rho > 0 ? Vec3(p.x() / rho, p.y() / rho, 0) : Vec3(1, 0, 0);
  if (rho <= radius && std::abs(p.z()) <= h) {
    // Inside: the nearer of the side and the caps.
    const double ds = radius - rho, dc = h - std::abs(p.z());
    if (ds < dc) return Vec3(radius * radial.x(), radius * radial.y(), p.z());
    return Vec3(p.x(), p.y(), std::copysign(h, p.z()));
  }
  // Outside: clamping to the solid gives the closest point.
  const double rc = std::min(rho, radius), zc = std::clamp(p.z(), -h, h);
  return Vec3(rc * radial.x(), rc * radial.y(), zc);
}

double cone_distance(const Vec3& p, double radius, double height) {
  // In the meridian half-plane (r, z): distance to the side segment (radius, 0) - (0, height)
  // and to the base segment (0, 0) - (radius, 0).
  const Eigen::Vector2d q(std::hypot(p.x(), p.y()), p.z());
  auto to_segment = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d d = b - a;
    const double t = std::clamp((q - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
    return (q - a - t * d).norm();
  };
  const double dist = std::min(to_segment({radius, 0}, {0, height}), to_segment({0, 0}, {radius, 0}));
  const bool inside = q.y() > 0 && q.y() < height * (1 - q.x() / radius);
  return inside ? -dist : dist;
}

double capped_cylinder_distance(const Vec3& p, double radius, double height) {
  const double dx = std::hypot(p.x(), p.y()) - radius, dz = std::abs(p.z()) - height / 2;
  const double out = std::hypot(std::max(dx, 0.0), std::max(dz, 0.0));
  return out + std::min(std::max(dx, dz), 0.0);
}

}  // namespace hocurve
