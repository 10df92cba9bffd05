// What the node's parts count, for diagnostics and the last log line: atomics, so that any thread
// adds and the diagnostics read without a lock.
#pragma once

#include <atomic>
#include <cstdint>

namespace landmark_loop_closure {

/// Seconds between repeats of one of the node's warnings.
constexpr double kWarningPeriod = 10.0;

struct NodeCounters {
  std::atomic<uint64_t> frames_admitted{0};
  std::atomic<uint64_t> map_keyframes{0};  ///< The database's size, set wherever it changes.
  std::atomic<uint32_t> session{0};        ///< The detector's.
  std::atomic<uint64_t> keyframes_over_budget{0};
  std::atomic<uint64_t> loops_published{0};
  std::atomic<uint64_t> tf_timeouts{0};
  std::atomic<uint64_t> odometry_jumps{0};
  std::atomic<uint64_t> keyframes_with_depth{0};
  std::atomic<uint64_t> keyframes_without_depth{0};
  /// Keyframes stored while or after ROS shut down, which may not have reached subscribers.
  std::atomic<uint64_t> keyframes_unpublished_at_shutdown{0};
  std::atomic<double> last_time_jump_wall{-1e9};  ///< When time_jump_frames last restarted time.
};

}  // namespace landmark_loop_closure
