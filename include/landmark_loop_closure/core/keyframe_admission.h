// The first, cheap step for every frame: input checks and the keyframe rule. It belongs to the
// thread that receives frames; the worker that describes keyframes only ever raises the next id
// (a map loaded with later ids), which is atomic. DetectorRuntime calls it without the detector's
// lock for that reason.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/keyframe_selector.h"

namespace landmark_loop_closure {

/// Outcome of the cheap first step for every frame.
struct FrameAdmission {
  std::optional<InputError> error;  ///< Set: refused, nothing changed.
  Selection selection{SelectionVerdict::kRedundant};
  uint64_t keyframe_id = 0;  ///< Id reserved for this frame when it is a keyframe.

  bool isKeyframe() const { return !error && selection.verdict == SelectionVerdict::kKeyframe; }
};

class KeyframeAdmission {
 public:
  KeyframeAdmission(const InputLimits& limits, const KeyframeSelectorOptions& keyframe);

  /// Validates stamp, pose and image shape, then applies the keyframe rule (`odometry`, when
  /// given, tells a camera gap from an odometry jump: KeyframeSelector::select). A keyframe gets
  /// the next id.
  FrameAdmission admit(double stamp, const Pose& pose, int image_width, int image_height,
                       int image_cv_type, const OdometrySince& odometry = nullptr);
  /// Forgets the last keyframe and image size, so that the next frame starts the keyframe rule
  /// afresh whatever its stamp (time jumped back).
  void restart();
  /// Stamp of the last admitted keyframe, if any.
  std::optional<double> lastKeyframeStamp() const;

  /// Any thread: keyframes from now on get ids from `next_id` on, unless they would already.
  void raiseNextId(uint64_t next_id);

 private:
  const InputLimits limits_;
  const KeyframeSelectorOptions keyframe_options_;
  KeyframeSelector selector_;
  std::optional<cv::Size> image_size_;
  std::atomic<uint64_t> next_keyframe_id_{0};
};

}  // namespace landmark_loop_closure
