// Elapsed wall time for the per-stage timings the detector and the tools report.
#pragma once

#include <chrono>

namespace landmark_loop_closure {

using Clock = std::chrono::steady_clock;

inline double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace landmark_loop_closure
