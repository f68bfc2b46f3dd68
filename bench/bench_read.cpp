// Read benchmark: hocurve's read_mesh_file + validate_mesh against gmsh::open on the same binary
// STL files (lat-long spheres of ~200k and ~2.4M triangles generated here).
// Usage: bench_read [output_dir=/tmp] [triangle counts, comma separated=200000,2400000] [nogmsh]
#include "engine/io/read_mesh.hpp"
#include "engine/io/validate_mesh.hpp"

#include <gmsh.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Unit lat-long sphere with nlon meridians and nlat parallels (poles as fans), written as a
/// binary STL of 2*nlon*(nlat-1) facets with outward CCW faces. Returns the facet count.
long long write_sphere_stl(const std::string& path, int nlon, int nlat) {
  auto P = [&](int i, int j) -> std::array<float, 3> {  // i: parallel 0..nlat (0 = north pole)
    const double th = M_PI * i / nlat, ph = 2 * M_PI * (j % nlon) / nlon;
    if (i == 0 || i == nlat) return {0.f, 0.f, i == 0 ? 1.f : -1.f};  // exact poles
    return {static_cast<float>(std::sin(th) * std::cos(ph)), static_cast<float>(std::sin(th) * std::sin(ph)),
            static_cast<float>(std::cos(th))};
  };
  std::vector<std::array<std::array<float, 3>, 3>> tris;
  for (int i = 0; i < nlat; ++i)
    for (int j = 0; j < nlon; ++j) {
      const auto a = P(i, j), b = P(i + 1, j), c = P(i + 1, j + 1), d = P(i, j + 1);
      if (i > 0) tris.push_back({a, b, d});
      if (i + 1 < nlat) tris.push_back({d, b, c});
    }
  std::string out(80, ' ');
  std::memcpy(out.data(), "hocurve bench_read lat-long sphere", 34);
  const std::uint32_t n = static_cast<std::uint32_t>(tris.size());
  out.append(reinterpret_cast<const char*>(&n), 4);
  out.reserve(84 + 50ull * n);
  for (const auto& t : tris) {
    float rec[12] = {0};
    for (int k = 0; k < 3; ++k) std::memcpy(rec + 3 + 3 * k, t[k].data(), 12);
    out.append(reinterpret_cast<const char*>(rec), 48);
    out.append(2, '\0');
  }
  std::ofstream(path, std::ios::binary).write(out.data(), static_cast<std::streamsize>(out.size()));
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : "/tmp";
  std::vector<long long> targets = {200000, 2400000};
  if (argc > 2) {
    targets.clear();
    std::stringstream ss(argv[2]);
    std::string t;
    while (std::getline(ss, t, ',')) targets.push_back(std::stoll(t));
  }
  const bool with_gmsh = !(argc > 3 && std::string(argv[3]) == "nogmsh");
  gmsh::initialize();
  gmsh::option::setNumber("General.Terminal", 0);
  std::printf("%10s %8s %10s %10s %10s %9s %8s  %s\n", "triangles", "MB", "read_s", "valid_s", "hocurve_s",
              "gmsh_s", "ratio", "vertices hocurve/gmsh");
  for (const long long target : targets) {
    // 2*nlon*(nlat-1) = target with nlon = 1.2*nlat keeps the quads near-square at the equator.
    const int nlat = std::max(3, static_cast<int>(std::sqrt(target / 2.4)));
    const int nlon = std::max(3, static_cast<int>(target / (2.0 * (nlat - 1))));
    const std::string path = dir + "/hocurve_bench_sphere_" + std::to_string(target) + ".stl";
    const long long nf = write_sphere_stl(path, nlon, nlat);
    const double mb = (84 + 50.0 * nf) / 1e6;

    double t0 = now();
    hocurve::ReadResult r = hocurve::read_mesh_file(path);
    const double t_read = now() - t0;
    t0 = now();
    hocurve::ValidateOptions vo;
    vo.name = path;
    const hocurve::ValidateReport vr = hocurve::validate_mesh(r.mesh, vo);
    const double t_valid = now() - t0;

    double t_gmsh = 0;
    std::vector<std::size_t> tags;
    if (with_gmsh) {
      t0 = now();
      gmsh::open(path);
      t_gmsh = now() - t0;
      std::vector<double> coord, pc;
      gmsh::model::mesh::getNodes(tags, coord, pc);
      gmsh::clear();
    }

    const double ours = t_read + t_valid;
    std::printf("%10lld %8.1f %10.3f %10.3f %10.3f %9.3f %8.1fx  %d/%zu%s\n", nf, mb, t_read, t_valid, ours, t_gmsh,
                t_gmsh / ours, r.mesh.num_vertices(), tags.size(),
                vr.boundary_edges || vr.flipped_faces ? "  (unexpected: open or flipped)" : "");
    std::fflush(stdout);
    std::remove(path.c_str());
  }
  gmsh::finalize();
  return 0;
}
