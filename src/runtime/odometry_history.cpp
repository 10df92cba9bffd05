#include "landmark_loop_closure/runtime/odometry_history.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {

Pose interpolatePose(const Pose& a, const Pose& b, double t) {
  Pose pose;
  pose.position = a.position + t * (b.position - a.position);
  pose.orientation = a.orientation.slerp(t, b.orientation).normalized();
  return pose;
}

bool OdometryHistory::add(double stamp, const Pose& pose) {
  const bool new_timeline =
      jump_back_s_ > 0.0 && !messages_.empty() && stamp < messages_.back().stamp - jump_back_s_;
  if (new_timeline) messages_.clear();
  const auto later =
      std::lower_bound(messages_.begin(), messages_.end(), stamp,
                       [](const Message& message, double value) { return message.stamp < value; });
  if (later != messages_.end() && std::abs(later->stamp - stamp) <= kSameStamp) {
    later->pose = pose;
    return new_timeline;
  }
  messages_.insert(later, Message{stamp, pose});
  while (messages_.size() > capacity_) messages_.pop_front();
  return new_timeline;
}

OdometryLookup OdometryHistory::at(double stamp, double max_interval) const {
  OdometryLookup lookup;
  if (messages_.empty()) return lookup;
  if (stamp > messages_.back().stamp + kSameStamp) {
    lookup.status = OdometryAt::kNotYet;
    return lookup;
  }
  if (stamp < messages_.front().stamp - kSameStamp) {
    lookup.status = OdometryAt::kBeforeHistory;
    return lookup;
  }
  const auto after =
      std::lower_bound(messages_.begin(), messages_.end(), stamp - kSameStamp,
                       [](const Message& message, double value) { return message.stamp < value; });
  if (std::abs(after->stamp - stamp) <= kSameStamp) {
    lookup.status = OdometryAt::kFound;
    lookup.pose = after->pose;
    return lookup;
  }
  const auto before = std::prev(after);  // Exists: stamp is after the oldest message.
  lookup.interval = after->stamp - before->stamp;
  if (lookup.interval > max_interval) {
    lookup.status = OdometryAt::kGapTooLong;
    return lookup;
  }
  lookup.status = OdometryAt::kFound;
  lookup.pose =
      interpolatePose(before->pose, after->pose, (stamp - before->stamp) / lookup.interval);
  return lookup;
}

std::vector<Pose> OdometryHistory::posesBetween(double from, double to, double max_interval) const {
  const OdometryLookup first = at(from, max_interval);
  const OdometryLookup last = at(to, max_interval);
  if (first.status != OdometryAt::kFound || last.status != OdometryAt::kFound || to < from) {
    return {};
  }
  std::vector<Pose> poses{first.pose};
  const auto after =
      std::upper_bound(messages_.begin(), messages_.end(), from + kSameStamp,
                       [](double value, const Message& message) { return value < message.stamp; });
  double previous = from;
  for (auto message = after; message != messages_.end() && message->stamp < to - kSameStamp;
       ++message) {
    if (message->stamp - previous > max_interval) return {};
    poses.push_back(message->pose);
    previous = message->stamp;
  }
  if (to - previous > max_interval) return {};
  poses.push_back(last.pose);
  return poses;
}

}  // namespace landmark_loop_closure
