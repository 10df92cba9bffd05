// The node's outputs: keyframes as the map commits them, loops, candidates, markers and the match
// image, published on the worker with the detector held (or by the fleet link, loops between
// robots).
#pragma once

#include <string>
#include <unordered_map>

#include <image_transport/image_transport.h>
#include <ros/ros.h>

#include "frame_source.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "loop_markers.h"
#include "node_counters.h"

namespace landmark_loop_closure {

class FleetLink;

class NodeOutputs {
 public:
  /// `detector_mutex`: the runtime's (DetectorRuntime::detectorMutex()), which guards what the
  /// outputs keep of the map.
  NodeOutputs(ros::NodeHandle node, ros::NodeHandle private_node, const NodeOptions& options,
              NodeCounters* counters, const Mutex& detector_mutex);
  NodeOutputs(const NodeOutputs&) = delete;
  NodeOutputs& operator=(const NodeOutputs&) = delete;

  /// For code the holder of the detector's lock runs through a std::function (the runtime's
  /// listener, withDetector): says so to the analysis; throws std::logic_error when not held.
  void assertDetectorHeld() const ASSERT_CAPABILITY(detector_mutex_) {
    detector_mutex_.assertHeld();
  }

  /// Keyframes announced are also handed to the fleet link (null: none).
  void setFleet(FleetLink* fleet) { fleet_ = fleet; }

  /// A keyframe described, searched and stored: its loop, candidates, markers, match image, and
  /// the keyframes the map committed meanwhile.
  void publishKeyframe(LoopDetector& detector, const NodeKeyframe& keyframe,
                       const KeyframeResult& result, const cv::Mat& grey) REQUIRES(detector_mutex_);
  /// Publishes the keyframes the map says are committed (MapSession::takeAnnounced), so that no
  /// published (map_id, id) is lost to a crash.
  void publishAnnounced(LoopDetector& detector) REQUIRES(detector_mutex_);
  /// The map was replaced or forgotten: its stamps and markers go.
  void forgetMap() REQUIRES(detector_mutex_);
  /// The last keyframe's image frame.
  std::string cameraFrame() const REQUIRES(detector_mutex_) { return keyframes_camera_frame_; }

  /// The loop's relative pose in the frame relative_pose_frame asks for, when possible; returns
  /// the frame it is in.
  std::string expressRelativePose(const LoopDetector& detector, AcceptedLoop* loop,
                                  const std::string& camera_frame) const;
  /// Any thread: a loop between robots.
  void publishLoop(const LoopClosure& loop);

 private:
  /// The original stamp of a keyframe, to the nanosecond (a loaded one's as its map keeps it).
  ros::Time stampOf(const LoopDetector& detector, uint64_t id) const REQUIRES(detector_mutex_);
  void publishMatchImage(const LoopDetector& detector, const NodeKeyframe& keyframe,
                         const KeyframeResult& result, const cv::Mat& grey);

  const NodeOptions& options_;
  NodeCounters& counters_;
  const Mutex& detector_mutex_;
  FleetLink* fleet_ = nullptr;
  ros::Publisher loop_publisher_;
  ros::Publisher keyframe_publisher_;
  ros::Publisher candidates_publisher_;
  ros::Publisher markers_publisher_;
  image_transport::Publisher match_image_publisher_;
  bool loop_shown_ = false;  ///< The match view holds the latest loop; worker thread only.
  LoopMarkers markers_;      ///< Thread-safe: the worker draws, a connecting viewer reads.
  std::unordered_map<uint64_t, ros::Time> keyframe_stamps_ GUARDED_BY(detector_mutex_);
  std::string keyframes_frame_id_ GUARDED_BY(detector_mutex_);  ///< The last keyframe's odometry.
  std::string keyframes_camera_frame_ GUARDED_BY(detector_mutex_);
};

}  // namespace landmark_loop_closure
