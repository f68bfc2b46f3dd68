// Coarse lifting benchmark: decimation + bijective map timings on ~200k-triangle analytic
// inputs and on shared meshes. Usage: bench_coarse [mesh-file target_faces [feature_angle]]
#include "engine/coarse/decimate.hpp"
#include "engine/core/topology.hpp"
#include "engine/io/read_mesh.hpp"
#include "tests/coarse/coarse_test_meshes.hpp"

#include <chrono>
#include <ctime>
#include <cstdio>
#include <random>
#include <string>

using namespace hocurve;

namespace {

void run(const std::string& name, const Mesh& fine, DecimateOptions opt) {
  for (bool with_map : {false, true}) {
    opt.build_map = with_map;
    const std::clock_t c0 = std::clock();
    const DecimateResult R = decimate(fine, opt);
    const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
    std::printf("%-22s map=%d  %7d -> %6d faces  cpu %.3f s, wall %.3f s (flatten %.3f s, tracking %.3f s)\n", name.c_str(),
                with_map, fine.num_faces(), R.coarse.num_faces(), cpu, R.seconds_total, R.seconds_flatten,
                R.seconds_tracking);
    std::printf("    %s\n", R.message.c_str());
    auto chi = [](const Mesh& m) {
      return m.num_vertices() - build_topology(m.F, m.num_vertices()).num_edges() + m.num_faces();
    };
    std::printf("    Euler characteristic: input %d, coarse %d\n", chi(fine), chi(R.coarse));
    if (!with_map) continue;
    // Query throughput and round-trip accuracy on random coarse points.
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> U(0, 1);
    std::uniform_int_distribution<int> Fc(0, R.coarse.num_faces() - 1);
    const double diag = (fine.V.colwise().maxCoeff() - fine.V.colwise().minCoeff()).norm();
    MapQueryStats st;
    double worst = 0;
    const int n = 20000;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      double a = U(rng), b = U(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const int f = Fc(rng);
      const Eigen::Vector3d bc(a, b, 1 - a - b);
      const SurfacePoint d = coarse_to_fine(R.map, f, bc, &st);
      const SurfacePoint c = fine_to_coarse(R.map, d.face, d.bary, &st);
      const Eigen::Vector3d x = bc[0] * R.coarse.V.row(R.coarse.F(f, 0)) + bc[1] * R.coarse.V.row(R.coarse.F(f, 1)) +
                                bc[2] * R.coarse.V.row(R.coarse.F(f, 2));
      worst = std::max(worst, (c.position - x).norm() / diag);
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("    %d coarse->fine->coarse round trips: %.3f s, %.1f collapse steps/query, worst %.2e diag, "
                "clamped %lld\n",
                n, s, double(st.steps) / (2 * n), worst, st.clamped);
    std::printf("    map memory: %.1f MB in %d collapse records\n",
                (R.map.rec_uv.size() * 16.0 + R.map.rec_face.size() * 8.0 + R.map.face_rec.size() * 4.0) / 1e6,
                R.map.num_collapses());
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc >= 3) {
      DecimateOptions opt;
      opt.target_faces = std::stoi(argv[2]);
      if (argc >= 4) opt.feature_angle_deg = std::stod(argv[3]);
      if (argc >= 4 && std::stod(argv[3]) >= 180) opt.preserve_features = false;
      run(argv[1], read_mesh_file(argv[1]).mesh, opt);
      return 0;
    }
    DecimateOptions opt;
    opt.target_faces = 5000;
    run("icosphere L7", coarse_test::icosphere(7), opt);
    run("torus 400x250", coarse_test::torus(400, 250, 1.0, 0.4), opt);
    const std::string bunny = std::string(HOCURVE_SHARED_DIR) + "/meshes/bunny_closed.obj";
    opt.target_faces = 264;
    run("bunny_closed 4% f35", read_mesh_file(bunny).mesh, opt);
    opt.feature_angle_deg = 60;  // organic surface: only real creases are features
    run("bunny_closed 4% f60", read_mesh_file(bunny).mesh, opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_coarse: %s\n", e.what());
    return 1;
  }
  return 0;
}
