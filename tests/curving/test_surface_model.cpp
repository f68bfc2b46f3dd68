// The record of which surface model placed each wedge's fit and each element.
#include "engine/curving/solf.hpp"
#include "engine/curving/stats_json.hpp"
#include "engine/curving/surface_model.hpp"
#include "engine/curving/test_meshes.hpp"

#include <doctest/doctest.h>

#include <numeric>

using namespace hocurve;

namespace {

long long total(const std::vector<SurfaceModel>& m) {
  const std::vector<long long> h = model_histogram(m);
  return std::accumulate(h.begin(), h.end(), 0LL);
}

long long count(const std::vector<SurfaceModel>& m, SurfaceModel which) {
  return model_histogram(m)[static_cast<int>(which)];
}

}  // namespace

TEST_CASE("surface_model: every element and wedge has one model, straight at order 1") {
  const Mesh sphere = icosphere(3);
  CurveOptions opt;
  opt.order = 1;
  const CurveResult R1 = curve_mesh(sphere, opt);
  CHECK(static_cast<int>(R1.face_models.size()) == sphere.num_faces());
  CHECK(count(R1.face_models, SurfaceModel::Straight) == sphere.num_faces());

  opt.order = 4;
  const CurveResult R4 = curve_mesh(sphere, opt);
  CHECK(total(R4.face_models) == sphere.num_faces());
  CHECK(total(R4.wedge_models) == R4.wedges);
  // A smooth closed surface without features: height fits or exact spheres, no bands or apexes.
  CHECK(count(R4.wedge_models, SurfaceModel::Ruled) == 0);
  CHECK(count(R4.wedge_models, SurfaceModel::ConeApex) == 0);
  CHECK(count(R4.face_models, SurfaceModel::Straight) == 0);
  const nlohmann::json stats = stats_json(R4);
  long long listed = 0;
  for (auto& [name, n] : stats["models"]["elements"].items()) listed += n.get<long long>();
  CHECK(listed == sphere.num_faces());
}

TEST_CASE("surface_model: a cone's apex and a capped cylinder's rims are recorded") {
  CurveOptions opt;
  opt.order = 4;
  const CurveResult cone = curve_mesh(cone_mesh(8, 24, 0.5, 1.0), opt);
  CHECK(count(cone.wedge_models, SurfaceModel::ConeApex) >= 1);
  const CurveResult cyl = curve_mesh(capped_cylinder(24, 8, 0.5, 1.0), opt);
  CHECK(count(cyl.face_models, SurfaceModel::PlanarPatch) > 0);  // the flat caps
}

TEST_CASE("surface_model: names are distinct") {
  for (int a = 0; a < static_cast<int>(SurfaceModel::Count); ++a)
    for (int b = a + 1; b < static_cast<int>(SurfaceModel::Count); ++b)
      CHECK(std::string(model_name(static_cast<SurfaceModel>(a))) != model_name(static_cast<SurfaceModel>(b)));
}
