// Wall-clock timing of the library's phases (the *_ms fields of its stats and results).
#pragma once

#include <chrono>

namespace shatter {

using Clock = std::chrono::steady_clock;

/// Milliseconds from t0 to now.
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace shatter
