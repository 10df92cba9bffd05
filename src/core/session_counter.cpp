#include "landmark_loop_closure/core/session_counter.h"

namespace landmark_loop_closure {

void SessionCounter::enter(uint64_t keyframe_id) {
  // Keyframes come in id order, so the session changes where the odometry did; a marked keyframe
  // that never came (refused, dropped) passes its mark to the next.
  const auto marks_end = restarts_.upper_bound(keyframe_id);
  const bool restarted = restarts_.begin() != marks_end;
  restarts_.erase(restarts_.begin(), marks_end);
  if (restarted && last_) ++session_;
}

PathLength SessionCounter::advance(const Pose& pose) {
  PathLength path;
  if (last_) {
    path = last_->session != session_ ? last_->path : extendPath(last_->path, last_->pose, pose);
  }
  last_ = PathEnd{pose, path, session_};
  return path;
}

void SessionCounter::restartAt(uint32_t first) {
  session_ = first;
  last_.reset();
}

}  // namespace landmark_loop_closure
