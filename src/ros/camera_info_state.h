// The latest camera_info, converted once, and whether it suits the images that come.
#pragma once

#include <optional>
#include <string>

#include <sensor_msgs/CameraInfo.h>
#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/geometry/camera_intrinsics.h"

namespace landmark_loop_closure {

/// Thread-safe: the camera_info callback writes, the image callbacks and the fleet link read,
/// the diagnostics read without waiting for anything but this.
class CameraInfoState {
 public:
  CameraInfoState(bool images_rectified, double warning_period_s)
      : images_rectified_(images_rectified), warnings_(warning_period_s) {}

  void received(const sensor_msgs::CameraInfo& info) EXCLUDES(mutex_);

  /// The intrinsics for an image of this size: invalid ones (and the problem) when the latest
  /// camera_info does not suit it, or none came.
  struct ForImage {
    CameraIntrinsics intrinsics;
    std::optional<CalibrationProblem> problem;
  };
  ForImage forImage(cv::Size image) const EXCLUDES(mutex_);
  /// Records whether camera_info suits a frame the runtime accepted (a refused 1x1 image says
  /// nothing about it); warns once per period and cause when not.
  void noteAccepted(const std::optional<CalibrationProblem>& problem) EXCLUDES(mutex_);

  /// The latest intrinsics as they came (invalid until one).
  CameraIntrinsics latest() const EXCLUDES(mutex_);
  bool seen() const EXCLUDES(mutex_);
  /// Why camera_info is unusable, or "".
  std::string problem() const EXCLUDES(mutex_);

 private:
  const bool images_rectified_;
  mutable Mutex mutex_;
  CameraIntrinsics intrinsics_ GUARDED_BY(mutex_);
  bool seen_ GUARDED_BY(mutex_) = false;
  std::string problem_ GUARDED_BY(mutex_);
  KindThrottle warnings_ GUARDED_BY(mutex_);  ///< One per cause.
};

}  // namespace landmark_loop_closure
