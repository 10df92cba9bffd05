#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/core/input_error.h"

namespace landmark_loop_closure {

struct InputMonitorOptions {
  double timeout_s = 5.0;               ///< An input silent this long is reported.
  double max_interval_s = 0.25;         ///< odometry_max_interval, named in the unpaired warning.
  double rejection_log_period_s = 5.0;  ///< One log line per kind of bad frame per period.
};

/// What the node knows about its inputs, apart from ROS so the rules are unit-tested: when images
/// and poses last came and with which stamps, whether images meet their poses, and how often each
/// kind of bad frame came. Times are wall seconds passed in by the caller; every method may be
/// called from any thread.
class InputMonitor {
 public:
  InputMonitor(const InputMonitorOptions& options, double now);

  void imageArrived(double now, double stamp);
  /// An odometry message, or a successful tf lookup in tf mode.
  void poseArrived(double now, double stamp);
  /// An image met its odometry within the slop.
  void paired(double now);
  /// Counts a refused frame; returns true when it should be logged (the first of its kind in
  /// rejection_log_period_s) and its count so far in `count`.
  bool rejected(InputErrorCode code, double now, uint64_t* count);

  bool imageSilent(double now) const;
  bool poseSilent(double now) const;
  /// "" or, when images and poses both arrive but none paired for timeout_s, one warning line
  /// with the newest stamps of each and how far apart they are.
  std::string unpaired(double now) const;

  struct Rates {
    double image_hz = 0.0;
    double pose_hz = 0.0;
  };
  /// Arrival rates since the previous call (or the start).
  Rates takeRates(double now);
  uint64_t images() const;
  uint64_t poses() const;
  std::map<InputErrorCode, uint64_t> rejections() const;

 private:
  const InputMonitorOptions options_;
  mutable Mutex mutex_;
  uint64_t images_ GUARDED_BY(mutex_) = 0;
  uint64_t poses_ GUARDED_BY(mutex_) = 0;
  double last_image_ GUARDED_BY(mutex_) = 0.0;
  double last_pose_ GUARDED_BY(mutex_) = 0.0;
  /// Starts at construction: inputs get timeout_s to pair.
  double last_paired_ GUARDED_BY(mutex_);
  double newest_image_stamp_ GUARDED_BY(mutex_) = 0.0;
  double newest_pose_stamp_ GUARDED_BY(mutex_) = 0.0;
  double rate_since_ GUARDED_BY(mutex_);
  uint64_t images_at_rate_ GUARDED_BY(mutex_) = 0;
  uint64_t poses_at_rate_ GUARDED_BY(mutex_) = 0;
  std::map<InputErrorCode, uint64_t> rejected_ GUARDED_BY(mutex_);
  std::map<InputErrorCode, double> last_rejection_log_ GUARDED_BY(mutex_);
};

}  // namespace landmark_loop_closure
