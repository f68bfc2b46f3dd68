// hocurve coarsen: decimate, map and lift a coarse curved mesh (coarse lifting issue).
#include "cli/commands.hpp"

#include "engine/core/error.hpp"

namespace hocurve::cli {

int run_coarsen(int, char**) {
  throw UsageError("coarsen is not available in this build yet (coarse lifting is in progress)");
}

}  // namespace hocurve::cli
