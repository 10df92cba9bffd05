// Which session (odometry frame) each keyframe is in, and how far the odometry travelled to it
// within its session. A session is a run of keyframes in one odometry frame: a load starts the
// map's next, and so does the odometry being re-initialised (marked on the keyframe after it).
#pragma once

#include <cstdint>
#include <optional>
#include <set>

#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

class SessionCounter {
 public:
  /// The session new keyframes get.
  uint32_t current() const { return session_; }

  /// The odometry was re-initialised before keyframe `keyframe_id`: that keyframe, or the next
  /// that comes if it never does, starts a new session.
  void markRestart(uint64_t keyframe_id) { restarts_.insert(keyframe_id); }
  /// Offline replays: the next keyframe admitted starts a new session (takePending()).
  void markPending() { pending_ = true; }
  /// Whether markPending() was called since the last take.
  bool takePending() {
    const bool pending = pending_;
    pending_ = false;
    return pending;
  }

  /// Keyframe `keyframe_id` is about to be described: a restart marked at or before it starts a
  /// new session, unless no keyframe came since the map started (its session is new already).
  void enter(uint64_t keyframe_id);
  /// The keyframe at `pose`'s path: the last keyframe's extended to it within a session, the
  /// last's carried over into a new one (the odometry's jump to its new frame is no distance
  /// travelled). Remembered as the last keyframe's.
  PathLength advance(const Pose& pose);

  /// Another map is searched: its sessions go on from `first`, with no keyframe before.
  void restartAt(uint32_t first);

 private:
  uint32_t session_ = 0;
  std::set<uint64_t> restarts_;  ///< Keyframe ids that start a new session.
  bool pending_ = false;
  struct PathEnd {
    Pose pose;
    PathLength path;
    uint32_t session = 0;
  };
  std::optional<PathEnd> last_;  ///< The last keyframe entered (stored or not).
};

}  // namespace landmark_loop_closure
