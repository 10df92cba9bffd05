#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Why a calibration cannot be used: `cause` is a short stable key (one log throttle each),
/// `text` one line naming the field and its values.
struct CalibrationProblem {
  std::string cause;
  std::string text;
};

/// The lens models of sensor_msgs/CameraInfo's distortion_model that keypoints are corrected for.
enum class LensDistortion {
  kNone,                ///< A pinhole camera, or rectified images.
  kPlumbBob,            ///< "plumb_bob": k1 k2 p1 p2 [k3] (OpenCV's radial-tangential model).
  kRationalPolynomial,  ///< "rational_polynomial": k1 k2 p1 p2 k3 k4 k5 k6.
  kEquidistant,         ///< "equidistant": k1 k2 k3 k4 (OpenCV's fisheye model).
  kUnsupported,         ///< Any other name (distortion_name says which): not usable.
};

/// The model named by camera_info's distortion_model: "" or "none" is kNone, an unknown name
/// kUnsupported (setLens() makes an all-zero D a pinhole whatever the name).
LensDistortion lensDistortionNamed(const std::string& name);

/// Intrinsics of the images given to the verifier (from sensor_msgs/CameraInfo's K, D and
/// distortion_model). Keypoints are corrected for the lens once, where they are found
/// (idealPixels): everything after works on a pinhole camera with the same K.
struct CameraIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  cv::Size image_size;  ///< The image size the values refer to.
  LensDistortion distortion = LensDistortion::kNone;
  std::string distortion_name;       ///< camera_info's distortion_model, for messages.
  std::vector<double> coefficients;  ///< camera_info's D, in its model's order.

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
  /// The same camera for an image resized to `size` (the distortion, on normalised
  /// coordinates, does not change).
  CameraIntrinsics scaledTo(cv::Size size) const;
  cv::Matx33d matrix() const { return {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0}; }
  /// The ray through an (ideal) pixel, on the plane z = 1.
  Eigen::Vector3d ray(const cv::Point2f& pixel) const {
    return {(pixel.x - cx) / fx, (pixel.y - cy) / fy, 1.0};
  }
  /// camera_info's distortion_model and D. All zeros under any name (simulators, drivers without
  /// a lens model) is a pinhole.
  void setLens(const std::string& model, std::vector<double> d);
  /// A lens model with a coefficient other than 0.
  bool distorted() const;
  /// Where keypoints found at `pixels` would be seen through a distortion-free lens with the
  /// same K (the pixels themselves without distortion).
  std::vector<cv::Point2f> idealPixels(const std::vector<cv::Point2f>& pixels) const;
  /// The inverse: where ideal pixels lie in the image.
  std::vector<cv::Point2f> imagePixels(const std::vector<cv::Point2f>& ideal) const;
};

}  // namespace landmark_loop_closure
