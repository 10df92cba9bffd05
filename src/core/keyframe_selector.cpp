#include "landmark_loop_closure/core/keyframe_selector.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace landmark_loop_closure {

const ParameterTable<KeyframeSelectorOptions>& KeyframeSelectorOptions::parameters() {
  using O = KeyframeSelectorOptions;
  static const auto table =
      ParameterTable<O>("advanced/keyframe/",
                        "Keyframes: M = translation_weight * |dt| + rotation_weight * |(roll, "
                        "pitch, yaw)| since the last keyframe. The defaults suit a handheld camera "
                        "or a wheeled robot at walking speed: a keyframe every ~0.3 m or ~17 deg.")
          .number("translation_weight", &O::translation_weight, atLeast(0), "per metre.")
          .number("rotation_weight", &O::rotation_weight, atLeast(0), "per radian.")
          .number("min_motion", &O::min_motion, atLeast(0),
                  "M below this: redundant frame, not a keyframe.")
          .number("max_motion", &O::max_motion, above(0),
                  "M above this: odometry jump (tracking lost?), frame refused and logged.")
          .number("max_time_gap", &O::max_time_gap, atLeast(0),
                  "seconds without a keyframe that force one even when standing still; 0 = off.")
          .integer("jump_reanchor_frames", &O::jump_reanchor_frames, between(0, 100000),
                   "after this many consecutive jump frames the odometry is taken as "
                   "re-initialised and the next frame becomes a keyframe, the first of a new "
                   "session (Keyframe.session: another odometry frame); 0 = never.")
          .evaluationOnly();
  return table;
}

std::string KeyframeSelectorOptions::validate() const {
  std::ostringstream errors;
  errors << parameters().check(*this);
  if (translation_weight + rotation_weight <= 0.0) {
    errors << "advanced/keyframe/translation_weight and advanced/keyframe/rotation_weight must not "
              "both be 0\n";
  }
  if (!(max_motion > min_motion)) {
    errors << "advanced/keyframe/max_motion (" << max_motion
           << ") must be greater than advanced/keyframe/min_motion (" << min_motion << ")\n";
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

bool KeyframeSelector::continuousSinceKeyframe(const std::vector<Pose>& path,
                                               const Pose& pose) const {
  if (path.size() < 2) return false;
  const Pose* previous = &last_keyframe_->pose;
  for (const Pose& next : path) {
    if (motion(*previous, next) > options_.max_motion) return false;
    previous = &next;
  }
  return motion(*previous, pose) <= options_.max_motion;
}

Selection KeyframeSelector::select(double stamp, const Pose& pose, const OdometrySince& odometry) {
  Selection selection{SelectionVerdict::kKeyframe};
  if (last_keyframe_) {
    selection.motion = motion(last_keyframe_->pose, pose);
    const bool time_gap_passed =
        options_.max_time_gap > 0.0 && stamp - last_keyframe_->stamp >= options_.max_time_gap;
    // Motion is measured from the last keyframe: after a camera gap it is the whole way driven
    // meanwhile, which only the odometry between can tell from a reset.
    if (selection.motion > options_.max_motion && odometry &&
        continuousSinceKeyframe(odometry(last_keyframe_->stamp), pose)) {
      selection.across_gap = true;
    } else if (selection.motion > options_.max_motion) {
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
