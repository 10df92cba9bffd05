#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// Motion rule M = w_t * ||dt|| + w_r * ||(roll, pitch, yaw)|| against the last keyframe.
/// The defaults suit a handheld camera or a wheeled robot at walking speed: a keyframe every
/// ~0.3 m or ~17 degrees of turn.
struct KeyframeSelectorOptions {
  double translation_weight = 1.0;  ///< w_t, per metre.
  double rotation_weight = 1.0;     ///< w_r, per radian.
  double min_motion = 0.3;          ///< M below this: redundant, not a keyframe.
  double max_motion = 5.0;          ///< M above this: odometry jump (lost tracking), refused.
  double max_time_gap = 0.0;        ///< Seconds without a keyframe that force one; 0 = off.
  /// After this many consecutive frames refused as jumps, the odometry is taken to have been
  /// re-initialised and the next frame becomes a keyframe again; 0 = never re-anchor.
  int jump_reanchor_frames = 15;

  /// Keys under keyframe/, documented in config/default.yaml.
  static const ParameterTable<KeyframeSelectorOptions>& parameters();
  /// Empty when valid, otherwise every problem, one per line.
  std::string validate() const;
};

enum class SelectionVerdict {
  kKeyframe,
  kRedundant,     ///< M < min_motion.
  kOdometryJump,  ///< M > max_motion.
};

const char* toString(SelectionVerdict verdict);

struct Selection {
  SelectionVerdict verdict;
  double motion = 0.0;          ///< M against the last keyframe (0 for the first frame).
  bool forced_by_time = false;  ///< Keyframe only because max_time_gap passed.
  bool reanchored = false;      ///< Keyframe accepted after a run of odometry jumps.
  /// Keyframe although M > max_motion: the frames stopped (a camera gap) while the odometry went
  /// on without a jump, so this is the same odometry frame and the same session.
  bool across_gap = false;
};

/// The odometry's poses from `since` (the last keyframe's stamp) to the frame being selected,
/// oldest first, the first at `since` and the last at the frame; empty when the odometry held
/// does not cover that span without a gap of its own.
using OdometrySince = std::function<std::vector<Pose>(double since)>;

/// Decides which frames become keyframes. Pure pose arithmetic, cheap enough for a
/// subscriber callback. Stamps and poses must already be validated.
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeSelectorOptions& options);

  /// M between two poses under this selector's weights.
  double motion(const Pose& from, const Pose& to) const;

  /// Classifies a frame; a keyframe becomes the new reference. M > max_motion is a jump unless
  /// `odometry` (when given) shows that the odometry moved there step by step, each step within
  /// max_motion: a camera gap while the robot drove on, not a reset.
  Selection select(double stamp, const Pose& pose, const OdometrySince& odometry = nullptr);

  bool hasKeyframe() const { return last_keyframe_.has_value(); }
  double lastKeyframeStamp() const;

 private:
  struct Reference {
    double stamp;
    Pose pose;
  };
  /// Whether `path` (OdometrySince's) joins the last keyframe to `pose` without a jump.
  bool continuousSinceKeyframe(const std::vector<Pose>& path, const Pose& pose) const;
  KeyframeSelectorOptions options_;
  std::optional<Reference> last_keyframe_;
  int consecutive_jumps_ = 0;
};

}  // namespace landmark_loop_closure
