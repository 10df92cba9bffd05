// A keyframe's images made ready for the detector on the worker, with the detector free: grey
// and colour, its registered depth image, and the camera's mount from tf.
#pragma once

#include <atomic>
#include <optional>
#include <string>

#include <image_transport/image_transport.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>

#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "landmark_loop_closure/runtime/stamped_buffer.h"
#include "node_counters.h"

namespace landmark_loop_closure {

class KeyframePreparation {
 public:
  /// `tf`: the node's buffer, needed (not null) when the mount is looked up in tf.
  KeyframePreparation(const NodeOptions& options, NodeCounters* counters, tf2_ros::Buffer* tf);

  /// Callback thread: subscribes to depth when use_depth.
  void subscribeDepth(image_transport::ImageTransport* transport);
  /// Callback thread: a keyframe at `stamp` was admitted; its depth image is kept for the worker.
  void wantDepth(double stamp);

  /// Worker thread (DetectorRuntime's prepare): false, with `error` set, refuses the keyframe.
  bool prepare(const sensor_msgs::Image& image, bool colour, PreparedKeyframe* prepared,
               InputError* error);

  /// Any thread: a depth publisher advertises and has sent nothing for a while.
  bool depthSilent() const { return depth_silence_reported_; }
  std::string depthTopic() const { return depth_subscriber_.getTopic(); }

  /// Depth images the subscriber and buffer keep.
  static constexpr uint32_t kDepthQueue = 30;

 private:
  void onDepth(const sensor_msgs::ImageConstPtr& depth);
  /// The depth image nearest `stamp` within sync_slop, waiting briefly for one still on its way;
  /// empty when none, or when it is not in `camera_frame` (unregistered) or unusable.
  cv::Mat depthFor(const ros::Time& stamp, const std::string& camera_frame);
  /// base_frame <- `camera_frame` from tf, into `prepared` (the runtime gives it to the detector
  /// under its lock); nothing while tf lacks it (and, with no mount configured, the default
  /// values are said once).
  void lookUpCameraMount(const std::string& camera_frame, PreparedKeyframe* prepared);

  const NodeOptions& options_;
  NodeCounters& counters_;
  tf2_ros::Buffer* const tf_;
  image_transport::Subscriber depth_subscriber_;
  StampedBuffer<sensor_msgs::ImageConstPtr> depth_buffer_{kDepthQueue};  ///< Callbacks fill.
  KindThrottle depth_warnings_;  ///< Worker only: the depth decoder's reasons.
  std::atomic<bool> depth_silence_reported_{false};
  // Worker only: the mount found in tf, and for which image frame.
  std::string mount_frame_;
  std::optional<Pose> mount_;
  bool default_mount_warned_ = false;
};

}  // namespace landmark_loop_closure
