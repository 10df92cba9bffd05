#pragma once

// A small detector for tests over PlaceExtractor images: keyframes every metre on a straight line,
// a 10-keyframe minimum database and a 5-keyframe exclusion window.

#include "landmark_loop_closure/core/loop_detector.h"
#include "place_extractor.h"

namespace landmark_loop_closure {
namespace test_support {

inline LoopDetectorOptions smallOptions() {
  LoopDetectorOptions options;
  options.keyframe.min_motion = 0.5;
  options.keyframe.max_motion = 10.0;
  options.database.exclude_recent_keyframes = 5;
  options.database.exclude_recent_seconds = 0.0;
  options.database.min_size = 10;
  options.acceptance.min_score = 0.5;
  options.acceptance.consistent_keyframes = 3;
  options.acceptance.index_window = 2;
  // These tests drive in a straight line and revisit places by appearance only, which the
  // odometry gate refuses; it has its own tests.
  options.odometry_gate.enabled = false;
  // PlaceExtractor's places score exactly 1 or 0 against each other, which these tests rely on;
  // standardisation has its own tests (and test_loop_detector turns it on once).
  options.descriptor.condition_window = 0;
  // Single-image scores and the k-keyframe chain; sequence matching has its own tests.
  options.acceptance.sequence.length = 1;
  // A few dozen places that score exactly 1 or 0: min_score decides; the calibrated decision
  // has its own tests (test_false_alarms) and the corridor's (test_loop_detector_sim).
  options.acceptance.max_false_alarms = 0.0;
  return options;
}

// Keyframe i at x = i metres, stamp i seconds, showing place `value`.
inline FrameResult feed(LoopDetector* detector, int i, int value) {
  return detector->process(i, planarPose(i, 0, 0), place(value));
}

}  // namespace test_support
}  // namespace landmark_loop_closure
