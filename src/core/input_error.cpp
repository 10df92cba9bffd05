#include "landmark_loop_closure/core/input_error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

const ParameterTable<InputLimits>& InputLimits::parameters() {
  using O = InputLimits;
  static const auto table =
      ParameterTable<O>("advanced/input/", "")
          .integer("min_image_side", &O::min_image_side, between(1, 4096),
                   "images with a side shorter than this (px) are dropped.")
          .integer("max_image_pixels", &O::max_image_pixels, between(1, 268435456),
                   "images with more pixels (8K = 7680x4320) are dropped as corrupt.")
          .number("quaternion_norm_tolerance", &O::quaternion_norm_tolerance,
                  openBetween(0, 1, true, true),
                  "|norm(q) - 1| above this drops the pose; below, q is renormalised.")
          .evaluationOnly()
          .number("min_image_contrast", &O::min_image_contrast, atLeast(0),
                  "keyframes whose grey levels spread less than this (0-255) between their 5th "
                  "and 95th percentiles are dropped (lens cap, white-out, a dark tunnel or night "
                  "without light): such images all look alike and would match each other. A "
                  "lamp or a logo on a dark frame is under 5 % of it and does not count. 0: off. "
                  "Chosen on Nordland's first half: its tunnels spread 0-5 levels, a lit dark "
                  "stretch 10-19, the frames that show the route 24 or more (bench/README.md).");
  return table;
}

const char* toString(InputErrorCode code) {
  switch (code) {
    case InputErrorCode::kEmptyImage:
      return "empty_image";
    case InputErrorCode::kImageTooSmall:
      return "image_too_small";
    case InputErrorCode::kImageTooLarge:
      return "image_too_large";
    case InputErrorCode::kImageSizeChanged:
      return "image_size_changed";
    case InputErrorCode::kUnsupportedImageType:
      return "unsupported_image_type";
    case InputErrorCode::kNonFiniteStamp:
      return "non_finite_stamp";
    case InputErrorCode::kUnsetStamp:
      return "unset_stamp";
    case InputErrorCode::kStampInFuture:
      return "stamp_in_future";
    case InputErrorCode::kStampNotIncreasing:
      return "stamp_not_increasing";
    case InputErrorCode::kNonFinitePose:
      return "non_finite_pose";
    case InputErrorCode::kPoseOutOfRange:
      return "pose_out_of_range";
    case InputErrorCode::kNonUnitQuaternion:
      return "non_unit_quaternion";
    case InputErrorCode::kNoTexture:
      return "no_texture";
    case InputErrorCode::kMalformedImage:
      return "malformed_image";
  }
  return "unknown";
}

std::optional<InputError> checkImage(int width, int height, int cv_type,
                                     const InputLimits& limits) {
  std::ostringstream message;
  if (width <= 0 || height <= 0) {
    message << "image is empty (" << width << "x" << height << ")";
    return InputError{InputErrorCode::kEmptyImage, message.str()};
  }
  if (width < limits.min_image_side || height < limits.min_image_side) {
    message << "image " << width << "x" << height << " is smaller than the minimum side of "
            << limits.min_image_side << " px";
    return InputError{InputErrorCode::kImageTooSmall, message.str()};
  }
  if (static_cast<long long>(width) * height > limits.max_image_pixels) {
    message << "image " << width << "x" << height << " has more than " << limits.max_image_pixels
            << " pixels";
    return InputError{InputErrorCode::kImageTooLarge, message.str()};
  }
  const int depth = CV_MAT_DEPTH(cv_type);
  const int channels = CV_MAT_CN(cv_type);
  if ((depth != CV_8U && depth != CV_16U) || (channels != 1 && channels != 3 && channels != 4)) {
    message << "image type " << cv::typeToString(cv_type)
            << " is not 8- or 16-bit with 1, 3 or 4 channels";
    return InputError{InputErrorCode::kUnsupportedImageType, message.str()};
  }
  return std::nullopt;
}

namespace {

// Grey levels between the 5th and 95th percentiles, the widest channel's: a bright patch under
// 5 % of the frame (a lamp, a broadcaster's logo) does not make a dark frame textured.
double percentileSpread(const cv::Mat& image) {
  cv::Mat eight_bit = image;
  if (image.depth() == CV_16U) image.convertTo(eight_bit, CV_8U, 1.0 / 257.0);
  const double pixels = static_cast<double>(eight_bit.total());
  double widest = 0.0;
  for (int c = 0; c < eight_bit.channels(); ++c) {
    std::array<double, 256> histogram{};
    for (int row = 0; row < eight_bit.rows; ++row) {
      const uint8_t* values = eight_bit.ptr<uint8_t>(row);
      for (int col = 0; col < eight_bit.cols; ++col) {
        histogram[values[col * eight_bit.channels() + c]] += 1.0;
      }
    }
    int low = -1;
    int high = 255;
    double below = 0.0;
    for (int level = 0; level < 256; ++level) {
      below += histogram[level];
      if (low < 0 && below >= 0.05 * pixels) low = level;
      if (below >= 0.95 * pixels) {
        high = level;
        break;
      }
    }
    widest = std::max(widest, static_cast<double>(high - std::max(low, 0)));
  }
  return widest;
}

}  // namespace

std::optional<InputError> checkTexture(const cv::Mat& image, const InputLimits& limits) {
  if (limits.min_image_contrast <= 0.0 || image.empty()) return std::nullopt;
  const double contrast = percentileSpread(image);
  if (contrast >= limits.min_image_contrast) return std::nullopt;
  const double mean = cv::mean(image)[0] / (image.depth() == CV_16U ? 257.0 : 1.0);
  std::ostringstream message;
  message.precision(3);
  message << "image has no texture: grey levels spread " << contrast
          << " between the 5th and 95th percentiles (mean " << mean
          << "), below advanced/input/min_image_contrast " << limits.min_image_contrast;
  return InputError{InputErrorCode::kNoTexture, message.str()};
}

std::optional<InputError> checkPose(const Pose& pose, const InputLimits& limits) {
  const Eigen::Vector4d q = pose.orientation.coeffs();
  if (!pose.position.allFinite() || !q.allFinite()) {
    std::ostringstream message;
    message << "pose has non-finite values: position (" << pose.position.transpose()
            << "), quaternion xyzw (" << q.transpose() << ")";
    return InputError{InputErrorCode::kNonFinitePose, message.str()};
  }
  if (pose.position.cwiseAbs().maxCoeff() > kMaxPoseCoordinateM) {
    std::ostringstream message;
    message << "pose position (" << pose.position.transpose() << ") is more than "
            << kMaxPoseCoordinateM << " m from the odometry's origin";
    return InputError{InputErrorCode::kPoseOutOfRange, message.str()};
  }
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > limits.quaternion_norm_tolerance) {
    std::ostringstream message;
    message << "pose quaternion has norm " << norm << ", expected 1 +- "
            << limits.quaternion_norm_tolerance;
    return InputError{InputErrorCode::kNonUnitQuaternion, message.str()};
  }
  return std::nullopt;
}

Pose normalisedPose(const Pose& pose) {
  Pose result = pose;
  result.orientation.normalize();
  return result;
}

}  // namespace landmark_loop_closure
