// The node's inputs: images paired with odometry or looked up in tf, camera_info and depth,
// admitted into the runtime on the callback thread; on the worker, a keyframe's images prepared.
#pragma once

#include <atomic>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "camera_info_state.h"
#include "keyframe_preparation.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "landmark_loop_closure/runtime/input_monitor.h"
#include "landmark_loop_closure/runtime/odometry_history.h"
#include "node_counters.h"

namespace landmark_loop_closure {

/// Threading: the subscriptions' callbacks and the tf retry timer run on the node's
/// single-threaded queue and never wait for the worker; prepare() is the worker's.
class NodeInputs {
 public:
  NodeInputs(ros::NodeHandle node, const NodeOptions& options, NodeCounters* counters);
  NodeInputs(const NodeInputs&) = delete;
  NodeInputs& operator=(const NodeInputs&) = delete;

  /// Subscribes (never lazily: a detector that stops listening loses keyframes for good) and
  /// hands every frame to `runtime`, which outlives the subscriptions.
  void start(DetectorRuntime* runtime);

  /// Worker thread (DetectorRuntime's prepare): the keyframe's images, depth and camera mount.
  bool prepare(const KeyframeJob& job, bool colour, PreparedKeyframe* prepared, InputError* error);
  /// Any thread: a frame or keyframe refused, said once per period and code.
  void reportRejected(const InputError& error);

  const CameraInfoState& cameraInfo() const { return camera_info_; }
  InputMonitor& monitor() { return monitor_; }
  const std::string& imageTopic() const { return image_topic_; }
  const std::string& odometryTopic() const { return odom_topic_; }
  std::string cameraInfoTopic() const { return camera_info_subscriber_.getTopic(); }
  const KeyframePreparation& preparation() const { return preparation_; }

 private:
  struct PendingImage {
    sensor_msgs::ImageConstPtr image;
    ros::WallTime received;
  };
  void onImageForOdometry(const sensor_msgs::ImageConstPtr& image);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  /// Admits, in stamp order, the held images the odometry now places; drops those it never will.
  void pairPendingWithOdometry();
  /// The odometry's pose as base_frame's: through tf when child_frame_id is another frame.
  std::optional<Pose> bodyPose(const nav_msgs::Odometry& odometry);
  void onImageForTf(const sensor_msgs::ImageConstPtr& image);
  void retryPendingTf();
  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& info) { camera_info_.received(*info); }
  /// `odometry_since`: the odometry up to this image, where the node holds it (not with tf).
  void admitFrame(const sensor_msgs::ImageConstPtr& image, const Pose& pose,
                  const std::string& frame_id, OdometrySince odometry_since = nullptr);
  /// Logs once which path the descriptor takes for images of this size (and why).
  void sayDescriptorPath(cv::Size image_size);

  ros::NodeHandle node_;
  const NodeOptions& options_;
  NodeCounters& counters_;
  DetectorRuntime* runtime_ = nullptr;  ///< From start().
  /// Made when first needed (pose or mount from tf, odometry of another child frame).
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  image_transport::ImageTransport image_transport_;
  image_transport::Subscriber image_subscriber_;
  ros::Subscriber odom_subscriber_;
  ros::Subscriber camera_info_subscriber_;
  std::string image_topic_;
  std::string odom_topic_;
  // Callback thread only: recent odometry and the images waiting for it (odometry), or for tf.
  OdometryHistory odometry_history_;
  std::string odometry_frame_;  ///< frame_id of the latest odometry message.
  std::deque<sensor_msgs::ImageConstPtr> pending_odometry_;
  std::deque<PendingImage> pending_tf_;
  ros::WallTimer tf_timer_;
  InputMonitor monitor_;  ///< Arrivals, pairing, bad frames: thread-safe.
  CameraInfoState camera_info_;
  KeyframePreparation preparation_;  ///< After tf_buffer_, which it looks the mount up in.
  /// Which path the descriptor takes has been logged (once, at the first image the detector was
  /// free for).
  std::atomic<bool> descriptor_path_said_{false};
};

}  // namespace landmark_loop_closure
