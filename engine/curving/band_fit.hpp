// Ruled fits for narrow bands between two feature curves (chamfers, thin fillets, CAD strips one
// triangle wide). There every stencil vertex lies on one of the two curves, so a height function
// is only known along two lines: terms like v(v - w) vanish on both and full-degree fits put
// garbage curvature across the band (measured: screw chamfer at diag/80, cross-edge nodes off by
// the chord's sagitta, 1.3e-2). A ruled model, degree p along the curve and linear across it,
// is what two curves determine.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/features.hpp"
#include "engine/curving/local_fit.hpp"
#include "engine/curving/stencil.hpp"

#include <vector>

namespace hocurve {

/// True when wedge w is a band wedge: its vertex is on a feature curve that runs straight through
/// the wedge (the two bounding feature edges turn by less than 60 degrees) and every other vertex
/// of the wedge's faces is a feature vertex too.
bool is_band_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat, int w);

/// Ruled fit of wedge w: height = sum_j a_j u^j + v sum_j b_j u^j (u along the feature curve,
/// v across it in the tangent plane of `base`, the wedge's ordinary fit), Gaussian weights as in
/// fit_wedge, degree lowered while the stencil leaves it rank deficient.
LocalFit fit_band_wedge(const Mesh& mesh, const Topology& T, const Wedges& W, const Features& feat,
                        int w, int p, const LocalFit& base, const FitOptions& opt);

/// Replaces the fit of every band wedge by its ruled fit (TBB-parallel, deterministic).
/// Returns the number of wedges refitted.
long long refit_band_wedges(const Mesh& mesh, const Topology& T, const Wedges& W,
                            const Features& feat, int p, const FitOptions& opt,
                            std::vector<LocalFit>& fits);

}  // namespace hocurve
