// Support points: area-weighted, uniform within faces, reproducible for a seed whatever the
// thread count.
#include "engine/core/error.hpp"
#include "engine/curving/support_points.hpp"
#include "engine/curving/test_meshes.hpp"

#include <doctest/doctest.h>
#include <tbb/task_arena.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <set>
#include <vector>

using namespace hocurve;

TEST_CASE("counter_uniform: in 0 <= u < 1, spread, independent of call order") {
  double sum = 0, sum2 = 0;
  const int n = 200000;
  std::set<double> seen;
  for (int i = 0; i < n; ++i) {
    const double u = counter_uniform(42, i, 3);
    REQUIRE(u >= 0.0);
    REQUIRE(u < 1.0);
    sum += u, sum2 += u * u;
    if (i < 1000) seen.insert(u);
  }
  CHECK(sum / n == doctest::Approx(0.5).epsilon(0.01));
  CHECK(sum2 / n - (sum / n) * (sum / n) == doctest::Approx(1.0 / 12).epsilon(0.01));
  CHECK(seen.size() == 1000);
  CHECK(counter_uniform(42, 7, 3) == counter_uniform(42, 7, 3));
  CHECK(counter_uniform(42, 7, 3) != counter_uniform(43, 7, 3));
  CHECK(counter_uniform(42, 7, 3) != counter_uniform(42, 3, 7));
}

TEST_CASE("samples lie on their faces with consistent barycentric coordinates") {
  const Mesh m = ellipsoid_mesh(3, 1.0, 0.8, 0.6);
  const SupportPoints S = sample_support(m);
  // Stochastic rounding: the total is right on average, within a few standard deviations.
  const double want = 3.0 * m.num_faces();
  CHECK(std::abs(S.count() - want) < 4 * std::sqrt(m.num_faces() / 4.0) + 1);
  REQUIRE(S.face.size() == S.count());
  REQUIRE(S.bary.rows() == S.count());
  for (int s = 0; s < S.count(); ++s) {
    const int f = S.face[s];
    REQUIRE(f >= 0);
    REQUIRE(f < m.num_faces());
    REQUIRE(S.bary.row(s).minCoeff() >= 0);
    REQUIRE(S.bary.row(s).sum() == doctest::Approx(1.0));
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int j = 0; j < 3; ++j) p += S.bary(s, j) * m.V.row(m.F(f, j));
    REQUIRE((p - S.P.row(s)).norm() < 1e-14);
  }
  // Sorted by face (CSR-like): consumers can find a face's samples by binary search.
  for (int s = 1; s < S.count(); ++s) REQUIRE(S.face[s - 1] <= S.face[s]);
  double area = 0;
  for (int f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  CHECK(S.total_area == doctest::Approx(area).epsilon(1e-12));
}

TEST_CASE("area weighting and uniform density inside a triangle") {
  // Two triangles of areas 1/2 and 3/2.
  Mesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 3, 0, 0, 3, 1.5, 0;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 1, 3, 4;
  SupportOptions opt;
  opt.per_face = 20000;
  const SupportPoints S = sample_support(m, opt);
  int n0 = 0;
  for (int s = 0; s < S.count(); ++s) n0 += S.face[s] == 0;
  CHECK(n0 == 10000);  // 40000 * (1/2) / 2: an integer expected count is exact
  CHECK(S.count() == 40000);
  // Uniform in the triangle: the mean is the centroid, and the sub-triangle where the first
  // barycentric coordinate exceeds 1/2 holds a quarter of the samples.
  Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
  int corner = 0;
  for (int s = 0; s < S.count(); ++s)
    if (S.face[s] == 1) mean += S.bary.row(s), corner += S.bary(s, 0) > 0.5;
  const int n1 = S.count() - n0;
  mean /= n1;
  for (int j = 0; j < 3; ++j) CHECK(mean[j] == doctest::Approx(1.0 / 3).epsilon(0.02));
  CHECK(static_cast<double>(corner) / n1 == doctest::Approx(0.25).epsilon(0.04));
}

TEST_CASE("reproducible for a seed, independent of the thread count") {
  const Mesh m = torus_grid(64, 24, 1.0, 0.3);
  SupportOptions opt;
  opt.seed = 99;
  SupportPoints one, two;
  tbb::task_arena(1).execute([&] { one = sample_support(m, opt); });
  tbb::task_arena(2).execute([&] { two = sample_support(m, opt); });
  CHECK(one.P == two.P);
  CHECK(one.face == two.face);
  CHECK(one.bary == two.bary);
  opt.seed = 100;
  const SupportPoints other = sample_support(m, opt);
  CHECK((other.count() != one.count() || other.P != one.P));
}

TEST_CASE("edge cases: zero samples, bad options, degenerate mesh") {
  SupportOptions none;
  none.per_face = 0;
  const SupportPoints S = sample_support(icosphere(1), none);
  CHECK(S.count() == 0);
  CHECK(S.faces_without_samples == 80);
  SupportOptions bad;
  bad.per_face = -1;
  CHECK_THROWS_AS(sample_support(icosphere(1), bad), InputError);
  bad.per_face = std::nan("");
  CHECK_THROWS_AS(sample_support(icosphere(1), bad), InputError);
  Mesh flat;  // zero total area: nothing to sample, no division by zero
  flat.V.resize(3, 3);
  flat.V << 0, 0, 0, 1, 0, 0, 2, 0, 0;
  flat.F.resize(1, 3);
  flat.F << 0, 1, 2;
  CHECK(sample_support(flat).count() == 0);
}
