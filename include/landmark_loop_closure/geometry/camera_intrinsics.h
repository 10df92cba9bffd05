#pragma once

#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Why a calibration cannot be used: `cause` is a short stable key (one log throttle each),
/// `text` one line naming the field and its values.
struct CalibrationProblem {
  std::string cause;
  std::string text;
};

/// Pinhole intrinsics of the images given to the verifier (from sensor_msgs/CameraInfo's K).
struct CameraIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  cv::Size image_size;  ///< The image size the values refer to.

  /// The plausibility rule a real pinhole camera meets: every value finite, a non-empty size, fx
  /// and fy between 0.05 and 100 image widths (a horizontal field of view between about 170 and
  /// 0.6 degrees), fy/fx between 0.5 and 2, and the principal point in the middle 80 % of the
  /// image in each direction.
  static constexpr double kMinFocalWidths = 0.05;
  static constexpr double kMaxFocalWidths = 100.0;
  static constexpr double kMaxPixelAspect = 2.0;
  static constexpr double kPrincipalPointMargin = 0.1;

  /// The first rule broken, naming the field; nullopt when usable.
  std::optional<CalibrationProblem> check() const;
  /// check(), or an aspect ratio other than `image`'s (camera_info of another camera).
  std::optional<CalibrationProblem> checkFor(cv::Size image) const;
  /// check()'s text, "" when usable.
  std::string problem() const;
  bool valid() const { return !check(); }
  /// The same camera for an image resized to `size`.
  CameraIntrinsics scaledTo(cv::Size size) const;
  cv::Matx33d matrix() const { return {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0}; }
};

}  // namespace landmark_loop_closure
