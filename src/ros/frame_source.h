// What the node hands the runtime with each frame (KeyframeJob::source), and the keyframe as the
// publishers need it.
#pragma once

#include <any>
#include <cstdint>
#include <string>

#include <ros/time.h>
#include <sensor_msgs/Image.h>

#include "landmark_loop_closure/geometry/pose.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"

namespace landmark_loop_closure {

struct FrameSource {
  sensor_msgs::ImageConstPtr image;
  std::string frame_id;  ///< The odometry frame of the pose.
};

struct NodeKeyframe {
  sensor_msgs::ImageConstPtr image;
  uint64_t id = 0;
  ros::Time stamp;  ///< The image's own stamp, to the nanosecond.
  Pose pose;
  std::string frame_id;  ///< The odometry frame of `pose`.

  static NodeKeyframe of(const KeyframeJob& job) {
    const auto& source = std::any_cast<const FrameSource&>(job.source);
    return {source.image, job.id, source.image->header.stamp, job.pose, source.frame_id};
  }
};

}  // namespace landmark_loop_closure
