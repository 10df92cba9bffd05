#pragma once

// Drives a running loop-closure node with the generated corridor sequence and records what it
// publishes.

#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <cv_bridge/cv_bridge.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_msgs/TFMessage.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/geometry/pose.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace landmark_loop_closure {
namespace test_support {

// Frames per second the tests publish: six times the generated camera's 10 Hz, so that the
// worker keeps up on two busy cores. Fed faster than it describes keyframes, the node drops the
// oldest queued ones by design, and the keyframe counts the tests check would fall.
constexpr double kPublishRateHz = 60.0;

class NodeHarness {
 public:
  NodeHarness() {
    image_publisher_ = node_.advertise<sensor_msgs::Image>("/camera/image_raw", 100);
    odom_publisher_ = node_.advertise<nav_msgs::Odometry>("/odom", 100);
    tf_publisher_ = node_.advertise<tf2_msgs::TFMessage>("/tf", 100);
    camera_info_publisher_ = node_.advertise<sensor_msgs::CameraInfo>("/camera/camera_info", 100);
    depth_publisher_ = node_.advertise<sensor_msgs::Image>("/camera/depth/image_raw", 100);
    static_tf_publisher_ = node_.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
    publishCameraMount();
    keyframe_subscriber_ = node_.subscribe("/keyframes", 1000, &NodeHarness::onKeyframe, this);
    loop_subscriber_ = node_.subscribe("/loop_closures", 1000, &NodeHarness::onLoop, this);
    diagnostics_subscriber_ =
        node_.subscribe("/diagnostics", 10, &NodeHarness::onDiagnostics, this);
    log_subscriber_ = node_.subscribe("/rosout", 1000, &NodeHarness::onLog, this);
  }

  /// Waits until the node listens to images and to its pose source (odometry or tf); false after
  /// `timeout` seconds.
  bool waitForNode(double timeout = 30.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && ros::WallTime::now() < end) {
      const bool pose_source_connected =
          odom_publisher_.getNumSubscribers() > 0 || tf_publisher_.getNumSubscribers() > 0;
      if (image_publisher_.getNumSubscribers() > 0 && pose_source_connected &&
          keyframe_subscriber_.getNumPublishers() > 0) {
        return true;
      }
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

  /// Waits until no node listens to the images any more (after stopping one); false after
  /// `timeout` seconds.
  bool waitForNodeGone(double timeout = 30.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && ros::WallTime::now() < end) {
      if (image_publisher_.getNumSubscribers() == 0 &&
          keyframe_subscriber_.getNumPublishers() == 0) {
        return true;
      }
      ros::spinOnce();
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

  /// The generated camera's K, as a calibrated driver sends it.
  static sensor_msgs::CameraInfo::_K_type calibratedK() {
    const sim::CameraModel camera;
    return {camera.focal_px,
            0.0,
            (camera.width - 1) / 2.0,
            0.0,
            camera.focal_px,
            (camera.height - 1) / 2.0,
            0.0,
            0.0,
            1.0};
  }
  /// From now on camera_info carries `k` (K all zeros: an uncalibrated driver).
  void setCameraMatrix(const sensor_msgs::CameraInfo::_K_type& k) { camera_matrix_ = k; }
  /// From now on camera_info names a plumb_bob lens with these coefficients (k1 k2 p1 p2 k3).
  void setLens(const std::vector<double>& plumb_bob) { lens_ = plumb_bob; }

  /// Publishes an image and its odometry (as nav_msgs/Odometry and as tf odom -> base_link) with
  /// the same stamp, or the odometry `odometry_offset` seconds later; `corrupt_pose` puts NaN in x.
  void publish(double stamp, const sim::Pose2D& odom, const cv::Mat& image,
               const std::string& encoding = "mono8", bool corrupt_pose = false,
               double odometry_offset = 0.0) {
    std_msgs::Header header;
    header.stamp = ros::Time(stamp);
    header.frame_id = "camera";
    sensor_msgs::ImagePtr message = cv_bridge::CvImage(header, "mono8", image).toImageMsg();
    message->encoding = encoding;
    nav_msgs::Odometry odometry;
    odometry.header.stamp = ros::Time(stamp + odometry_offset);
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    odometry.pose.pose.position.x =
        corrupt_pose ? std::numeric_limits<double>::quiet_NaN() : odom.x;
    odometry.pose.pose.position.y = odom.y;
    odometry.pose.pose.orientation.z = std::sin(0.5 * odom.yaw);
    odometry.pose.pose.orientation.w = std::cos(0.5 * odom.yaw);
    odom_publisher_.publish(odometry);
    geometry_msgs::TransformStamped transform;
    transform.header = odometry.header;
    transform.child_frame_id = odometry.child_frame_id;
    transform.transform.translation.x = odometry.pose.pose.position.x;
    transform.transform.translation.y = odometry.pose.pose.position.y;
    transform.transform.rotation = odometry.pose.pose.orientation;
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(transform);
    if (!corrupt_pose) tf_publisher_.publish(tf);  // tf itself refuses NaN transforms.
    image_publisher_.publish(message);
    const sim::CameraModel camera;
    sensor_msgs::CameraInfo info;
    info.header = header;
    info.width = static_cast<uint32_t>(camera.width);
    info.height = static_cast<uint32_t>(camera.height);
    info.K = camera_matrix_;
    if (!lens_.empty()) {
      info.distortion_model = "plumb_bob";
      info.D = lens_;
    }
    camera_info_publisher_.publish(info);
  }

  /// Publishes odometry alone (nav_msgs/Odometry and tf), as while the camera is silent.
  void publishOdometry(double stamp, const sim::Pose2D& odom) {
    nav_msgs::Odometry odometry;
    odometry.header.stamp = ros::Time(stamp);
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    odometry.pose.pose.position.x = odom.x;
    odometry.pose.pose.position.y = odom.y;
    odometry.pose.pose.orientation.z = std::sin(0.5 * odom.yaw);
    odometry.pose.pose.orientation.w = std::cos(0.5 * odom.yaw);
    odom_publisher_.publish(odometry);
  }

  /// Publishes frames [first, last) of the generated corridor at kPublishRateHz, the odometry
  /// (and tf) `odometry_offset` s after each image; returns how many were published.
  size_t publishCorridor(size_t first, size_t last, double odometry_offset = 0.0,
                         double start_stamp = sim::SequenceOptions{}.start_stamp) {
    const sim::CorridorWorld world;
    sim::SequenceOptions options;
    options.start_stamp = start_stamp;
    sim::SequenceGenerator sequence(world, sim::CameraModel{}, options);
    ros::WallRate rate(kPublishRateHz);
    sim::SequenceFrame frame;
    size_t published = 0;
    while (ros::ok() && sequence.next(&frame) && frame.index < last) {
      if (frame.index < first) continue;
      publish(frame.stamp, frame.odom, frame.image, "mono8", false, odometry_offset);
      ++published;
      ros::spinOnce();
      rate.sleep();
    }
    return published;
  }

  /// Whether the node listens to depth images (parameter use_depth).
  bool depthWanted() const { return depth_publisher_.getNumSubscribers() > 0; }

  /// A depth image (32FC1, metres) registered to the image of the same stamp.
  void publishDepth(double stamp, const cv::Mat& depth) {
    std_msgs::Header header;
    header.stamp = ros::Time(stamp);
    header.frame_id = "camera";
    depth_publisher_.publish(cv_bridge::CvImage(header, "32FC1", depth).toImageMsg());
  }

  /// Spins until no keyframe arrived for `quiet` seconds (or `timeout` passed).
  void waitUntilQuiet(double quiet = 2.0, double timeout = 60.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    last_output_ = ros::WallTime::now();
    // Silence alone is not the end: the worker may still have a queue on a busy machine; the
    // diagnostics say so.
    const auto busy = [this] {
      // A node that is gone (killed by the test) says nothing more: its last word is not held.
      if ((ros::WallTime::now() - last_diagnostics_).toSec() > 3.0) return false;
      const std::string queued = diagnostic("queued keyframes");
      return !queued.empty() && queued != "0";
    };
    while (ros::ok() && ros::WallTime::now() < end &&
           ((ros::WallTime::now() - last_output_).toSec() < quiet || busy())) {
      ros::spinOnce();
      ros::WallDuration(0.01).sleep();
    }
  }

  const std::map<uint64_t, ros::Time>& keyframes() const { return keyframes_; }
  /// Every keyframe message, in the order received (keyframes() keeps one per id).
  const std::vector<Keyframe>& publishedKeyframes() const { return published_keyframes_; }
  /// Session of each keyframe published, by id.
  const std::map<uint64_t, uint32_t>& keyframeSessions() const { return keyframe_sessions_; }
  const std::vector<LoopClosure>& loops() const { return loops_; }
  /// Last value of a key in the node's diagnostics; empty when never seen.
  std::string diagnostic(const std::string& key) const {
    const auto it = diagnostics_.find(key);
    return it == diagnostics_.end() ? std::string() : it->second;
  }
  /// How many of the node's log lines (on /rosout) contained `text`.
  size_t loggedCount(const std::string& text) const {
    size_t count = 0;
    for (const std::string& line : log_lines_) count += line.find(text) != std::string::npos;
    return count;
  }
  /// Spins until the node logged a line containing `text`; false after `timeout` seconds.
  bool waitForLog(const std::string& text, double timeout = 5.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && loggedCount(text) == 0 && ros::WallTime::now() < end) {
      ros::spinOnce();
      ros::WallDuration(0.02).sleep();
    }
    return loggedCount(text) > 0;
  }
  /// Whether a diagnostics summary of the node ever contained `text`.
  bool summarySaid(const std::string& text) const {
    for (const std::string& summary : summaries_) {
      if (summary.find(text) != std::string::npos) return true;
    }
    return false;
  }

 private:
  // The generated camera on the robot, latched on /tf_static as a robot description would: the
  // default camera_mount rotation, 1.2 m above base_link (sim::CameraModel::height_m).
  void publishCameraMount() {
    const Pose mount = CameraMount{0.0, 0.0, sim::CameraModel{}.height_m}.toPose();
    geometry_msgs::TransformStamped transform;
    transform.header.frame_id = "base_link";
    transform.child_frame_id = "camera";
    transform.transform.translation.x = mount.position.x();
    transform.transform.translation.y = mount.position.y();
    transform.transform.translation.z = mount.position.z();
    transform.transform.rotation.w = mount.orientation.w();
    transform.transform.rotation.x = mount.orientation.x();
    transform.transform.rotation.y = mount.orientation.y();
    transform.transform.rotation.z = mount.orientation.z();
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(transform);
    static_tf_publisher_.publish(tf);
  }

  void onKeyframe(const KeyframeConstPtr& keyframe) {
    published_keyframes_.push_back(*keyframe);
    keyframes_[keyframe->id] = keyframe->header.stamp;
    keyframe_sessions_[keyframe->id] = keyframe->session;
    last_output_ = ros::WallTime::now();
  }
  void onLoop(const LoopClosureConstPtr& loop) { loops_.push_back(*loop); }
  void onLog(const rosgraph_msgs::LogConstPtr& log) {
    if (log->name.find("loop_closure") != std::string::npos) log_lines_.push_back(log->msg);
  }
  void onDiagnostics(const diagnostic_msgs::DiagnosticArrayConstPtr& array) {
    last_diagnostics_ = ros::WallTime::now();
    for (const auto& status : array->status) {
      if (status.name.find("loop closure") == std::string::npos) continue;
      for (const auto& value : status.values) diagnostics_[value.key] = value.value;
      summaries_.insert(status.message);
    }
  }

  ros::NodeHandle node_;
  ros::Publisher image_publisher_;
  ros::Publisher odom_publisher_;
  ros::Publisher tf_publisher_;
  ros::Publisher camera_info_publisher_;
  sensor_msgs::CameraInfo::_K_type camera_matrix_ = calibratedK();
  std::vector<double> lens_;
  ros::Publisher depth_publisher_;
  ros::Publisher static_tf_publisher_;
  ros::Subscriber keyframe_subscriber_;
  ros::Subscriber loop_subscriber_;
  ros::Subscriber diagnostics_subscriber_;
  ros::Subscriber log_subscriber_;
  std::vector<std::string> log_lines_;
  std::map<uint64_t, ros::Time> keyframes_;
  std::vector<Keyframe> published_keyframes_;
  std::map<uint64_t, uint32_t> keyframe_sessions_;
  std::vector<LoopClosure> loops_;
  std::map<std::string, std::string> diagnostics_;
  std::set<std::string> summaries_;
  ros::WallTime last_output_;
  ros::WallTime last_diagnostics_;
};

}  // namespace test_support
}  // namespace landmark_loop_closure
