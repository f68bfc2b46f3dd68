// Wall-clock timing of the stages (their results report seconds).
#pragma once
#include <chrono>

namespace hocurve {

using Clock = std::chrono::steady_clock;

/// Seconds elapsed since t.
inline double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace hocurve
