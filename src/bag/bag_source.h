#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/keyframe_selector.h"
#include "landmark_loop_closure/eval/detector_evaluation.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

struct BagSourceOptions {
  std::string path;
  std::string image_topic = "/camera/image_raw";
  std::string odom_topic = "/odom";
  std::string truth_topic;  ///< nav_msgs/Odometry with ground truth; empty = none.
  double sync_slop = 0.05;  ///< Seconds between an image and its truth pose.
  /// The node's odometry_max_interval: an image's odometry is interpolated to its stamp between
  /// the messages around it, at most this many seconds apart.
  double odometry_max_interval = 0.25;
  KeyframeSelectorOptions keyframe;
};

/// The keyframes a node would keep from a bag: images with the odometry interpolated to their
/// stamps as the node does it (OdometryHistory), then the keyframe rule. Truth poses are paired the
/// same way when a truth topic is given.
struct BagKeyframes {
  std::vector<cv::Mat> images;  ///< 8-bit grey.
  std::vector<double> stamps;
  std::vector<Pose> odometry;
  std::vector<Pose> truth;  ///< Empty without a truth topic.
  size_t images_read = 0;
  size_t images_without_odometry = 0;
  size_t images_rejected = 0;          ///< Bad encoding, pose or stamp.
  size_t keyframes_without_truth = 0;  ///< Given their odometry pose as truth instead.
};

/// Throws std::runtime_error naming the bag and the problem.
BagKeyframes readBagKeyframes(const BagSourceOptions& options);

/// Every image of a bag as the node receives it: with the odometry interpolated to its stamp
/// (images the odometry cannot place are skipped), converted as the node converts it (grey, or
/// BGR when `colour`), with the intrinsics of the last camera_info before it in the bag, and its
/// truth pose (the truth topic's nearest, else the odometry). Images the node would refuse as
/// messages (bad encoding or size) are skipped too. Throws std::runtime_error like
/// readBagKeyframes.
using BagFrameSink =
    std::function<void(size_t index, const eval::DetectorFrame& frame, const Pose& truth)>;
void playBagFrames(const BagSourceOptions& options, bool colour, const BagFrameSink& sink);

}  // namespace landmark_loop_closure
