// Which surface model placed each wedge's fit and each element's nodes: the record of the
// curving's choices (stats "models", and per-element output fields).
#pragma once
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"
#include "engine/highorder/high_order_mesh.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hocurve {

enum class SurfaceModel : std::uint8_t {
  Straight,       ///< no fit: the straight triangle (order 1, or a corner without a sane fit)
  HeightPlane,    ///< height polynomial over the tangent plane
  HeightTorus,    ///< height polynomial over the osculating torus
  HeightQuadric,  ///< height polynomial over the stencil's quadric
  Ruled,          ///< ruled band fit between two feature curves (band_fit.hpp)
  ConeApex,       ///< cone model round an apex (apex_fit.hpp)
  ExactPlane,     ///< the stencil's exact plane (exact_quadric.hpp)
  ExactQuadric,   ///< the stencil's exact quadric
  ExactCyclide,   ///< the stencil's exact Darboux cyclide
  Blend,          ///< an element whose corners' fits are of different models
  LongEdge,       ///< an element with an edge the fits do not reach: its PN triangle (long_edges.hpp)
  PlanarPatch,    ///< an element of a flat patch, on its plane (planar_patches.hpp)
  Bounded,        ///< offsets its fits' tangent planes contradict, scaled down (offset_bound.hpp)
  Repaired,       ///< moved by the untangling or the validity repair
  Count
};

/// Stable lower-case name of a model (stats keys, output fields).
const char* model_name(SurfaceModel m);

/// The model of one wedge's fit; band: the wedge was refitted as a ruled band.
SurfaceModel wedge_model(const LocalFit& fit, bool band);

/// The model of an element placed by the blend of its corners' fits (Blend where they differ).
SurfaceModel corner_blend_model(SurfaceModel a, SurfaceModel b, SurfaceModel c);

/// Per wedge (#wedges): wedge_model of its fit (band wedges: refit_band_wedges made them ruled).
std::vector<SurfaceModel> wedge_models(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat,
                                       const std::vector<LocalFit>& fits);

/// Per face (#faces), the model that placed its nodes, from the last stage that moved them: its
/// corners' blend (corner_blend_model), a neighbour's exact surface (on_exact, per face: the
/// quadric's or cyclide's model), a PN triangle (long_face), its flat patch's plane (planar >= 0),
/// the offset bound (bounded). Empty vectors: that stage moved nothing.
std::vector<SurfaceModel> placement_models(const Mesh& mesh, const Wedges& W,
                                           const std::vector<SurfaceModel>& per_wedge,
                                           const std::vector<const LocalFit*>& on_exact,
                                           const std::vector<char>& long_face, const std::vector<int>& planar,
                                           const std::vector<char>& bounded);

/// Per face (#faces): a checksum of its edge and face nodes; a face whose checksum changed was moved.
std::vector<double> node_checksums(const HighOrderMesh& hm);

/// Counts per model, indexed by SurfaceModel (size SurfaceModel::Count).
std::vector<long long> model_histogram(const std::vector<SurfaceModel>& models);

}  // namespace hocurve
