#include "landmark_loop_closure/core/keyframe_selector.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace landmark_loop_closure {

std::string KeyframeSelectorOptions::validate() const {
  std::ostringstream errors;
  if (!(translation_weight >= 0.0) || !(rotation_weight >= 0.0) ||
      translation_weight + rotation_weight <= 0.0) {
    errors << "keyframe/translation_weight and keyframe/rotation_weight must be >= 0 and not both "
              "0 (got "
           << translation_weight << ", " << rotation_weight << ")\n";
  }
  if (!(min_motion >= 0.0))
    errors << "keyframe/min_motion must be >= 0 (got " << min_motion << ")\n";
  if (!(max_motion > min_motion)) {
    errors << "keyframe/max_motion (" << max_motion
           << ") must be greater than keyframe/min_motion (" << min_motion << ")\n";
  }
  if (!(max_time_gap >= 0.0)) {
    errors << "keyframe/max_time_gap must be >= 0, 0 = off (got " << max_time_gap << ")\n";
  }
  if (jump_reanchor_frames < 0) {
    errors << "keyframe/jump_reanchor_frames must be >= 0 (got " << jump_reanchor_frames << ")\n";
  }
  return errors.str();
}

const char* toString(SelectionVerdict verdict) {
  switch (verdict) {
    case SelectionVerdict::kKeyframe:
      return "keyframe";
    case SelectionVerdict::kRedundant:
      return "redundant";
    case SelectionVerdict::kOdometryJump:
      return "odometry_jump";
  }
  return "unknown";
}

KeyframeSelector::KeyframeSelector(const KeyframeSelectorOptions& options) : options_(options) {}

double KeyframeSelector::motion(const Pose& from, const Pose& to) const {
  const Eigen::Isometry3d delta = from.toIsometry().inverse() * to.toIsometry();
  const double translation = delta.translation().norm();
  const double rotation = rollPitchYaw(Eigen::Quaterniond(delta.linear())).norm();
  return options_.translation_weight * translation + options_.rotation_weight * rotation;
}

Selection KeyframeSelector::select(double stamp, const Pose& pose) {
  Selection selection{SelectionVerdict::kKeyframe};
  if (last_keyframe_) {
    selection.motion = motion(last_keyframe_->pose, pose);
    const bool time_gap_passed =
        options_.max_time_gap > 0.0 && stamp - last_keyframe_->stamp >= options_.max_time_gap;
    if (selection.motion > options_.max_motion) {
      ++consecutive_jumps_;
      if (options_.jump_reanchor_frames == 0 ||
          consecutive_jumps_ <= options_.jump_reanchor_frames) {
        selection.verdict = SelectionVerdict::kOdometryJump;
        return selection;
      }
      selection.reanchored = true;
    } else if (selection.motion < options_.min_motion) {
      consecutive_jumps_ = 0;
      if (!time_gap_passed) {
        selection.verdict = SelectionVerdict::kRedundant;
        return selection;
      }
      selection.forced_by_time = true;
    }
  }
  consecutive_jumps_ = 0;
  last_keyframe_ = Reference{stamp, pose};
  return selection;
}

double KeyframeSelector::lastKeyframeStamp() const {
  return last_keyframe_ ? last_keyframe_->stamp : -std::numeric_limits<double>::infinity();
}

}  // namespace landmark_loop_closure
