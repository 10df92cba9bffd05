#pragma once

#include <cstddef>
#include <deque>
#include <string>
#include <vector>

#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// What the odometry says about one image stamp.
enum class OdometryAt {
  kFound,          ///< Interpolated between the messages around it (or one at its stamp).
  kNotYet,         ///< After the newest message: wait for the next one.
  kBeforeHistory,  ///< Before the oldest message held: it will never be known.
  kGapTooLong,     ///< The messages around it are further apart than allowed.
  kNoOdometry,     ///< Nothing held yet.
};

struct OdometryLookup {
  OdometryAt status = OdometryAt::kNoOdometry;
  Pose pose;              ///< kFound: the body's pose at the stamp.
  double interval = 0.0;  ///< kFound / kGapTooLong: seconds between the messages around it.
};

/// The recent odometry messages by stamp, so that an image's pose is the odometry interpolated
/// to the image's own stamp (position linearly, orientation by slerp) rather than the nearest
/// message's, which can be half a message period away. Out-of-order messages are inserted in
/// place; a message at a stamp already held replaces it. A message more than `jump_back_s` older
/// than the newest starts a new timeline (a bag played again, a simulator's clock reset): what is
/// held is forgotten, or a full history would refuse every message of the new timeline as older
/// than all it holds.
class OdometryHistory {
 public:
  /// Messages stamped within this of an image's stamp are taken as at it.
  static constexpr double kSameStamp = 1e-6;

  /// `jump_back_s` 0: never a new timeline (an offline reader holding a whole bag).
  explicit OdometryHistory(size_t capacity = 2000, double jump_back_s = 0.0)
      : capacity_(capacity == 0 ? 1 : capacity), jump_back_s_(jump_back_s) {}

  /// True when the message started a new timeline (everything held before was forgotten).
  bool add(double stamp, const Pose& pose);
  /// The pose at `stamp` when the messages around it are at most `max_interval` s apart.
  OdometryLookup at(double stamp, double max_interval) const;
  /// The poses from `from` to `to`: the pose at `from`, every message between, the pose at
  /// `to`; empty when either is not found (at()) or messages anywhere between are more than
  /// `max_interval` apart (the odometry itself stopped).
  std::vector<Pose> posesBetween(double from, double to, double max_interval) const;
  void clear() { messages_.clear(); }
  size_t size() const { return messages_.size(); }
  double newest() const { return messages_.empty() ? 0.0 : messages_.back().stamp; }

 private:
  struct Message {
    double stamp;
    Pose pose;
  };
  size_t capacity_;
  double jump_back_s_;
  std::deque<Message> messages_;  ///< Oldest first.
};

/// The pose a fraction `t` in [0, 1] of the way from `a` to `b`: position linear, orientation
/// slerp (the shorter way round).
Pose interpolatePose(const Pose& a, const Pose& b, double t);

}  // namespace landmark_loop_closure
