#include "landmark_loop_closure/core/keyframe_admission.h"

#include <cmath>
#include <sstream>

namespace landmark_loop_closure {

KeyframeAdmission::KeyframeAdmission(const InputLimits& limits,
                                     const KeyframeSelectorOptions& keyframe)
    : limits_(limits), keyframe_options_(keyframe), selector_(keyframe) {}

FrameAdmission KeyframeAdmission::admit(double stamp, const Pose& pose, int image_width,
                                        int image_height, int image_cv_type,
                                        const OdometrySince& odometry) {
  FrameAdmission admission;
  if (!std::isfinite(stamp)) {
    admission.error = InputError{InputErrorCode::kNonFiniteStamp, "stamp is not finite"};
    return admission;
  }
  if (selector_.hasKeyframe() && stamp <= selector_.lastKeyframeStamp()) {
    std::ostringstream message;
    message.precision(17);
    message << "stamp " << stamp << " s is not after the last keyframe's "
            << selector_.lastKeyframeStamp() << " s";
    admission.error = InputError{InputErrorCode::kStampNotIncreasing, message.str()};
    return admission;
  }
  if ((admission.error = checkPose(pose, limits_))) return admission;
  if ((admission.error = checkImage(image_width, image_height, image_cv_type, limits_))) {
    return admission;
  }
  const cv::Size size(image_width, image_height);
  if (image_size_ && *image_size_ != size) {
    std::ostringstream message;
    message << "image size " << image_width << "x" << image_height
            << " differs from the first image's " << image_size_->width << "x"
            << image_size_->height;
    admission.error = InputError{InputErrorCode::kImageSizeChanged, message.str()};
    return admission;
  }
  image_size_ = size;
  admission.selection = selector_.select(stamp, normalisedPose(pose), odometry);
  if (admission.selection.verdict == SelectionVerdict::kKeyframe) {
    admission.keyframe_id = next_keyframe_id_++;
  }
  return admission;
}

void KeyframeAdmission::restart() {
  selector_ = KeyframeSelector(keyframe_options_);
  image_size_.reset();
}

std::optional<double> KeyframeAdmission::lastKeyframeStamp() const {
  if (!selector_.hasKeyframe()) return std::nullopt;
  return selector_.lastKeyframeStamp();
}

void KeyframeAdmission::raiseNextId(uint64_t next_id) {
  uint64_t next = next_keyframe_id_.load();
  while (next < next_id && !next_keyframe_id_.compare_exchange_weak(next, next_id)) {
  }
}

}  // namespace landmark_loop_closure
