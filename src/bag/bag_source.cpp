#include "bag/bag_source.h"

#include <limits>
#include <map>
#include <stdexcept>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/runtime/odometry_history.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

// The pose whose stamp is nearest `stamp`, if within `slop`.
const Pose* nearest(const std::map<ros::Time, Pose>& poses, const ros::Time& stamp, double slop) {
  if (poses.empty()) return nullptr;
  auto after = poses.lower_bound(stamp);
  auto best = after;
  if (after == poses.end() ||
      (after != poses.begin() && (stamp - std::prev(after)->first) < (after->first - stamp))) {
    best = std::prev(after);
  }
  return std::abs((best->first - stamp).toSec()) <= slop ? &best->second : nullptr;
}

void openBag(const BagSourceOptions& options, rosbag::Bag* bag) {
  try {
    bag->open(options.path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& error) {
    throw std::runtime_error("cannot read bag " + options.path + ": " + error.what());
  }
}

// Poses first: a bag's odometry may be written after the image it belongs to.
void readPoses(const BagSourceOptions& options, rosbag::Bag& bag, OdometryHistory* odometry,
               std::map<ros::Time, Pose>* truth) {
  std::vector<std::string> pose_topics = {options.odom_topic};
  if (!options.truth_topic.empty()) pose_topics.push_back(options.truth_topic);
  for (const rosbag::MessageInstance& message :
       rosbag::View(bag, rosbag::TopicQuery(pose_topics))) {
    if (const auto pose = message.instantiate<nav_msgs::Odometry>()) {
      if (message.getTopic() == options.odom_topic) {
        odometry->add(toSeconds(pose->header.stamp), fromRos(pose->pose.pose));
      } else {
        (*truth)[pose->header.stamp] = fromRos(pose->pose.pose);
      }
    }
  }
  if (odometry->size() == 0) {
    throw std::runtime_error(options.path + " has no nav_msgs/Odometry on " + options.odom_topic);
  }
  if (!options.truth_topic.empty() && truth->empty()) {
    throw std::runtime_error(options.path + " has no nav_msgs/Odometry on " + options.truth_topic);
  }
}

}  // namespace

void playBagFrames(const BagSourceOptions& options, bool colour, const BagFrameSink& sink) {
  rosbag::Bag bag;
  openBag(options, &bag);
  OdometryHistory odometry(std::numeric_limits<size_t>::max());
  std::map<ros::Time, Pose> truth;
  readPoses(options, bag, &odometry, &truth);
  const std::string info_topic =
      options.image_topic.substr(0, options.image_topic.rfind('/') + 1) + "camera_info";
  // The node pairs an image with its odometry when the later of the two arrives, by which time
  // the camera_info of that stamp has come too: the latest one stamped at or before the image.
  std::map<ros::Time, CameraIntrinsics> infos;
  for (const rosbag::MessageInstance& message :
       rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{info_topic}))) {
    if (const auto info = message.instantiate<sensor_msgs::CameraInfo>()) {
      infos[info->header.stamp] = fromCameraInfo(*info);
    }
  }
  size_t index = 0;
  size_t images = 0;
  for (const rosbag::MessageInstance& message :
       rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{options.image_topic}))) {
    const auto image = message.instantiate<sensor_msgs::Image>();
    if (!image) continue;
    ++images;
    const OdometryLookup lookup =
        odometry.at(toSeconds(image->header.stamp), options.odometry_max_interval);
    if (lookup.status != OdometryAt::kFound || checkImageMessage(*image)) continue;
    const Pose& pose = lookup.pose;
    eval::DetectorFrame frame;
    frame.stamp = toSeconds(image->header.stamp);
    frame.pose = pose;
    frame.image = colour ? toBgr(*image) : toGrey(*image);
    const auto info = infos.upper_bound(image->header.stamp);
    if (info != infos.begin()) frame.intrinsics = std::prev(info)->second;
    const Pose* true_pose = options.truth_topic.empty()
                                ? nullptr
                                : nearest(truth, image->header.stamp, options.sync_slop);
    sink(index++, frame, true_pose ? *true_pose : pose);
  }
  if (images == 0) {
    throw std::runtime_error(options.path + " has no sensor_msgs/Image on " + options.image_topic);
  }
}

BagKeyframes readBagKeyframes(const BagSourceOptions& options) {
  rosbag::Bag bag;
  openBag(options, &bag);
  OdometryHistory odometry(std::numeric_limits<size_t>::max());
  std::map<ros::Time, Pose> truth;
  readPoses(options, bag, &odometry, &truth);

  BagKeyframes keyframes;
  KeyframeSelector selector(options.keyframe);
  const InputLimits limits;
  for (const rosbag::MessageInstance& message :
       rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{options.image_topic}))) {
    const auto image = message.instantiate<sensor_msgs::Image>();
    if (!image) continue;
    ++keyframes.images_read;
    const OdometryLookup lookup =
        odometry.at(toSeconds(image->header.stamp), options.odometry_max_interval);
    if (lookup.status != OdometryAt::kFound) {
      ++keyframes.images_without_odometry;
      continue;
    }
    const Pose& pose = lookup.pose;
    const double stamp = toSeconds(image->header.stamp);
    if (checkImageMessage(*image) || checkPose(pose, limits) ||
        (selector.hasKeyframe() && stamp <= selector.lastKeyframeStamp())) {
      ++keyframes.images_rejected;
      continue;
    }
    if (selector.select(stamp, normalisedPose(pose)).verdict != SelectionVerdict::kKeyframe) {
      continue;
    }
    keyframes.images.push_back(toGrey(*image));
    keyframes.stamps.push_back(stamp);
    keyframes.odometry.push_back(normalisedPose(pose));
    if (!options.truth_topic.empty()) {
      const Pose* true_pose = nearest(truth, image->header.stamp, options.sync_slop);
      keyframes.keyframes_without_truth += true_pose ? 0 : 1;
      keyframes.truth.push_back(normalisedPose(true_pose ? *true_pose : pose));
    }
  }
  if (keyframes.images_read == 0) {
    throw std::runtime_error(options.path + " has no sensor_msgs/Image on " + options.image_topic);
  }
  return keyframes;
}

}  // namespace landmark_loop_closure
