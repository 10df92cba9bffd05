#pragma once

#include <map>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// Why a frame was refused. Refused frames change nothing that is already stored.
enum class InputErrorCode {
  kEmptyImage,
  kImageTooSmall,
  kImageTooLarge,
  kImageSizeChanged,
  kUnsupportedImageType,
  kNonFiniteStamp,
  kUnsetStamp,  ///< Stamp 0: a driver that never set header.stamp; no time order is possible.
  kStampNotIncreasing,
  kStampInFuture,  ///< Ahead of the receiving clock: it would wedge every later frame.
  kNonFinitePose,
  kPoseOutOfRange,  ///< A coordinate beyond kMaxPoseCoordinateM: a corrupt message.
  kNonUnitQuaternion,
  kNoTexture,  ///< Nearly uniform image (lens cap, darkness, overexposure): all such look alike.
  kMalformedImage,  ///< Row step or data length that cannot hold the stated size and encoding.
};

const char* toString(InputErrorCode code);

struct InputError {
  InputErrorCode code;
  std::string message;  ///< One line for a log: what was wrong, with the offending values.
};

struct InputLimits {
  int min_image_side = 16;             ///< Smaller images carry no usable structure.
  int max_image_pixels = 7680 * 4320;  ///< 8K; larger frames are almost surely corrupt.
  double quaternion_norm_tolerance =
      1e-2;  ///< |‖q‖ - 1| above this is refused, below renormalised.
  /// Grey levels (0-255 scale) between the 5th and 95th percentiles below which an image has no
  /// texture to recognise a place by; 0 turns the check off.
  double min_image_contrast = 16.0;

  /// Keys under input/, documented in config/default.yaml; validated with the detector's options.
  static const ParameterTable<InputLimits>& parameters();
};

/// Checks image dimensions and type (8- or 16-bit, 1, 3 or 4 channels).
std::optional<InputError> checkImage(int width, int height, int cv_type, const InputLimits& limits);

/// Checks that an image has texture: the spread of its grey levels between the 5th and 95th
/// percentiles (the widest channel's; 8 or 16 bit, scaled to 0-255) reaches
/// limits.min_image_contrast.
std::optional<InputError> checkTexture(const cv::Mat& image, const InputLimits& limits);

/// Checks that a pose is finite and its quaternion close to unit norm.
std::optional<InputError> checkPose(const Pose& pose, const InputLimits& limits);

/// Pose with its quaternion normalised; call only on a pose that passed checkPose.
Pose normalisedPose(const Pose& pose);

/// Which warnings to log: each kind at most once per period. ROS_WARN_THROTTLE throttles per line
/// of code, so where one line reports several kinds of problem, a second kind would stay hidden
/// behind the first's silence; this keeps one silence per kind.
class KindThrottle {
 public:
  explicit KindThrottle(double period_s) : period_s_(period_s) {}
  /// Whether a warning of `kind` may be logged at `now_s` (seconds, any steady clock); counts it
  /// as logged when so.
  bool allow(const std::string& kind, double now_s) {
    const auto last = last_s_.find(kind);
    if (last != last_s_.end() && now_s - last->second < period_s_) return false;
    last_s_[kind] = now_s;
    return true;
  }

 private:
  double period_s_;
  std::map<std::string, double> last_s_;
};

}  // namespace landmark_loop_closure
