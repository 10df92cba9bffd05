#pragma once

#include <string>
#include <vector>

#include <visualization_msgs/MarkerArray.h>

#include "landmark_loop_closure/core/loop_detector.h"

namespace landmark_loop_closure {

/// What rviz shows: keyframe positions (blue), verified loops green (brighter and wider the
/// higher their score), loops published without the geometric check orange, optionally rejected
/// candidates grey, and a legend saying so above the first keyframe. Every marker is one rviz
/// accepts: a namespace with nothing to draw is sent as DELETE, never as an empty point list.
class LoopMarkers {
 public:
  LoopMarkers(std::string frame_id, double min_score, bool show_rejected);

  void addKeyframe(const Pose& pose);
  void addLoop(const AcceptedLoop& loop);
  void addRejected(const Pose& query, const Pose& match);
  void setFrameId(const std::string& frame_id) { frame_id_ = frame_id; }
  /// Forgets everything drawn (a database loaded or reset).
  void clear();

  visualization_msgs::MarkerArray toMsg(const ros::Time& stamp) const;

 private:
  std::string frame_id_;
  double min_score_;
  bool show_rejected_;
  std::vector<geometry_msgs::Point> keyframes_;
  std::vector<geometry_msgs::Point> loop_ends_;
  std::vector<std_msgs::ColorRGBA> loop_colours_;
  std::vector<geometry_msgs::Point> unverified_ends_;
  std::vector<geometry_msgs::Point> rejected_ends_;
};

}  // namespace landmark_loop_closure
