#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Pinhole intrinsics of the images given to the verifier (from sensor_msgs/CameraInfo's K).
struct CameraIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  cv::Size image_size;  ///< The image size the values refer to.

  /// "" when usable, else the first problem, naming the field: non-finite values, fx or fy not
  /// positive or implausibly large (over 100 image widths), an empty size, the principal point
  /// outside the image.
  std::string problem() const;
  /// problem(), or an aspect ratio other than `image`'s (camera_info of another camera).
  std::string problemFor(cv::Size image) const;
  bool valid() const { return problem().empty(); }
  /// The same camera for an image resized to `size`.
  CameraIntrinsics scaledTo(cv::Size size) const;
  cv::Matx33d matrix() const { return {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0}; }
};

}  // namespace landmark_loop_closure
