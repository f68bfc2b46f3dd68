#include "engine/curving/surface_model.hpp"

#include "engine/curving/band_fit.hpp"

#include <tbb/parallel_for.h>

namespace hocurve {

const char* model_name(SurfaceModel m) {
  switch (m) {
    case SurfaceModel::Straight: return "straight";
    case SurfaceModel::HeightPlane: return "height_plane";
    case SurfaceModel::HeightTorus: return "height_torus";
    case SurfaceModel::HeightQuadric: return "height_quadric";
    case SurfaceModel::Ruled: return "ruled_band";
    case SurfaceModel::ConeApex: return "cone_apex";
    case SurfaceModel::ExactPlane: return "exact_plane";
    case SurfaceModel::ExactQuadric: return "exact_quadric";
    case SurfaceModel::ExactCyclide: return "exact_cyclide";
    case SurfaceModel::Blend: return "blend";
    case SurfaceModel::LongEdge: return "long_edge_pn";
    case SurfaceModel::PlanarPatch: return "planar_patch";
    case SurfaceModel::Bounded: return "bounded";
    case SurfaceModel::Repaired: return "repaired";
    case SurfaceModel::Count: break;
  }
  return "unknown";
}

SurfaceModel wedge_model(const LocalFit& fit, bool band) {
  if (fit.apex) return SurfaceModel::ConeApex;
  if (fit.exact && fit.surface)
    return fit.surface->plane() ? SurfaceModel::ExactPlane
           : fit.surface->cyclide() ? SurfaceModel::ExactCyclide
                                    : SurfaceModel::ExactQuadric;
  if (fit.identity) return SurfaceModel::Straight;
  if (band) return SurfaceModel::Ruled;
  if (fit.quadric_ref) return SurfaceModel::HeightQuadric;
  if (fit.k1 != 0 || fit.k2 != 0) return SurfaceModel::HeightTorus;
  return SurfaceModel::HeightPlane;
}

SurfaceModel corner_blend_model(SurfaceModel a, SurfaceModel b, SurfaceModel c) {
  return a == b && b == c ? a : SurfaceModel::Blend;
}

std::vector<SurfaceModel> wedge_models(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat,
                                       const std::vector<LocalFit>& fits) {
  std::vector<SurfaceModel> m(W.num_wedges(), SurfaceModel::Straight);
  tbb::parallel_for(0, std::min(W.num_wedges(), static_cast<int>(fits.size())), [&](int w) {
    m[w] = wedge_model(fits[w], is_band_wedge(mesh, T, W, feat, w));
  });
  return m;
}

std::vector<SurfaceModel> placement_models(const Mesh& mesh, const Wedges& W,
                                           const std::vector<SurfaceModel>& per_wedge,
                                           const std::vector<const LocalFit*>& on_exact,
                                           const std::vector<char>& long_face, const std::vector<int>& planar,
                                           const std::vector<char>& bounded) {
  const int nf = mesh.num_faces();
  std::vector<SurfaceModel> m(nf, SurfaceModel::Straight);
  auto set = [](const auto& v, int f) { return f < static_cast<int>(v.size()) && v[f]; };
  for (int f = 0; f < nf && !per_wedge.empty(); ++f) {
    m[f] = corner_blend_model(per_wedge[W.corner_wedge(f, 0)], per_wedge[W.corner_wedge(f, 1)],
                              per_wedge[W.corner_wedge(f, 2)]);
    if (set(on_exact, f)) m[f] = wedge_model(*on_exact[f], false);
    if (set(long_face, f)) m[f] = SurfaceModel::LongEdge;
    if (f < static_cast<int>(planar.size()) && planar[f] >= 0) m[f] = SurfaceModel::PlanarPatch;
    if (set(bounded, f)) m[f] = SurfaceModel::Bounded;
  }
  return m;
}

std::vector<double> node_checksums(const HighOrderMesh& hm) {
  const int nf = hm.num_faces(), npe = hm.nodes_per_edge(), npf = hm.nodes_per_face();
  std::vector<double> sum(nf, 0.0);
  auto add = [](double& s, const auto& row) { s += row(0) + 3.0 * row(1) + 7.0 * row(2); };
  tbb::parallel_for(0, nf, [&](int f) {
    double s = 0;
    for (int j = 0; j < 3 && hm.FE.rows() == nf; ++j)
      for (int k = 0; k < npe; ++k) add(s, hm.edge_nodes.row(static_cast<Eigen::Index>(hm.FE(f, j)) * npe + k));
    for (int k = 0; k < npf; ++k) add(s, hm.face_nodes.row(static_cast<Eigen::Index>(f) * npf + k));
    sum[f] = s;
  });
  return sum;
}

std::vector<long long> model_histogram(const std::vector<SurfaceModel>& models) {
  std::vector<long long> h(static_cast<int>(SurfaceModel::Count), 0);
  for (SurfaceModel m : models) ++h[static_cast<int>(m)];
  return h;
}

}  // namespace hocurve
