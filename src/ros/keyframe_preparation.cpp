#include "keyframe_preparation.h"

#include <tf2_eigen/tf2_eigen.h>

#include "landmark_loop_closure/geometry/metric_pose.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

constexpr double kDepthWait = 0.2;     // Seconds the worker waits for a keyframe's depth image.
constexpr double kDepthSilence = 1.0;  // Seconds of stamps without depth: the stream stopped.

}  // namespace

KeyframePreparation::KeyframePreparation(const NodeOptions& options, NodeCounters* counters,
                                         tf2_ros::Buffer* tf)
    : options_(options), counters_(*counters), tf_(tf), depth_warnings_(kWarningPeriod) {}

void KeyframePreparation::subscribeDepth(image_transport::ImageTransport* transport) {
  if (!options_.use_depth) return;
  // Every queued keyframe (and the one in the worker) keeps its depth image however far behind
  // the worker is.
  depth_buffer_.setMaxWanted(static_cast<size_t>(options_.worker_queue_size) + 2);
  // As deep as the buffer: with callbacks late on a busy machine, a queue of 5 dropped the
  // depth of an image the image queue kept.
  depth_subscriber_ =
      transport->subscribe("depth", kDepthQueue, &KeyframePreparation::onDepth, this);
}

void KeyframePreparation::wantDepth(double stamp) {
  // The worker may reach this keyframe after its depth image left the buffer's window.
  if (options_.use_depth) depth_buffer_.want(stamp, options_.sync_slop);
}

void KeyframePreparation::onDepth(const sensor_msgs::ImageConstPtr& depth) {
  depth_buffer_.push(depth->header.stamp.toSec(), depth);
  if (depth_silence_reported_.exchange(false)) {
    ROS_INFO("Depth images arrive on %s again", depth_subscriber_.getTopic().c_str());
  }
}

bool KeyframePreparation::prepare(const sensor_msgs::Image& image, bool colour,
                                  PreparedKeyframe* prepared, InputError* error) {
  try {
    prepared->grey = toGrey(image);
    prepared->image = colour ? toBgr(image) : prepared->grey;
  } catch (const cv::Exception& exception) {
    *error = {InputErrorCode::kUnsupportedImageType, exception.what()};
    return false;
  }
  const std::string& camera_frame = image.header.frame_id;
  if (options_.camera_mount_from_tf || options_.mountFromTfWhereKnown()) {
    lookUpCameraMount(camera_frame, prepared);
  }
  if (options_.use_depth) {
    prepared->depth = depthFor(image.header.stamp, camera_frame);
    ++(prepared->depth.empty() ? counters_.keyframes_without_depth
                               : counters_.keyframes_with_depth);
  }
  return true;
}

cv::Mat KeyframePreparation::depthFor(const ros::Time& stamp, const std::string& camera_frame) {
  StampedWait wait;
  wait.slop_s = options_.sync_slop;
  wait.max_wait_s = kDepthWait;
  wait.silence_s = kDepthSilence;
  const std::optional<sensor_msgs::ImageConstPtr> nearest =
      depth_buffer_.nearest(stamp.toSec(), wait, depth_subscriber_.getNumPublishers() > 0);
  if (!nearest && depth_buffer_.silent()) {
    // A publisher that never publishes: one bounded wait, then keyframes go on without depth at
    // their normal speed until a depth image comes.
    if (!depth_silence_reported_.exchange(true)) {
      ROS_WARN(
          "No depth image came on %s within %.1f s although %u publisher(s) advertise it: "
          "keyframes go on without depth, not waiting for it again until one comes (use_depth)",
          depth_subscriber_.getTopic().c_str(), kDepthWait, depth_subscriber_.getNumPublishers());
    }
    return {};
  }
  if (!nearest) {
    ROS_WARN_THROTTLE(
        kWarningPeriod,
        "No depth image within advanced/sync_slop %.3f s of the keyframe at %.3f: its "
        "keypoint depths are triangulated instead (if enabled)",
        options_.sync_slop, stamp.toSec());
    return {};
  }
  std::string error;
  std::string kind;
  const sensor_msgs::Image& depth_image = **nearest;
  cv::Mat depth = toDepth(depth_image, &error, &kind);
  if (!error.empty()) {
    if (depth_warnings_.allow(kind, ros::WallTime::now().toSec())) {
      ROS_WARN("Depth image at %.3f not used: %s", depth_image.header.stamp.toSec(), error.c_str());
    }
    return {};
  }
  if (!hasUsableDepth(depth)) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Depth image at %.3f not used: no finite positive reading in it (all zero, "
                      "NaN, Inf or negative)",
                      depth_image.header.stamp.toSec());
    return {};
  }
  // Depth from another camera's frame would put every point in the wrong place.
  if (depth_image.header.frame_id != camera_frame) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Depth image not used: its frame '%s' is not the image's '%s' (subscribe to "
                      "a depth topic registered to the image)",
                      depth_image.header.frame_id.c_str(), camera_frame.c_str());
    return {};
  }
  return depth;
}

void KeyframePreparation::lookUpCameraMount(const std::string& camera_frame,
                                            PreparedKeyframe* prepared) {
  if (mount_ && camera_frame == mount_frame_) {
    // Given again with every keyframe: one the runtime dropped (a map switch) never gave it.
    prepared->camera_mount = mount_;
    return;
  }
  if (!options_.camera_mount_from_tf) {
    // No value set: tf's mount where tf has it, else the default values, said once.
    std::string error;
    if (camera_frame.empty() ||
        !tf_->canTransform(options_.base_frame, camera_frame, ros::Time(0), &error)) {
      const std::string warning = options_.defaultMountWarning();
      if (!warning.empty() && !default_mount_warned_) {
        ROS_WARN("%s", warning.c_str());
        default_mount_warned_ = true;
      }
      return;
    }
  } else if (camera_frame.empty()) {
    ROS_WARN_THROTTLE(
        kWarningPeriod,
        "Images carry no frame_id, so advanced/camera_mount/from_tf cannot look the camera "
        "up in tf: keypoint depths are not triangulated");
    return;
  }
  std::string error;
  if (!tf_->canTransform(options_.base_frame, camera_frame, ros::Time(0), &error)) {
    prepared->camera_mount = std::optional<Pose>();
    ROS_WARN_THROTTLE(
        kWarningPeriod,
        "No tf %s -> %s yet for advanced/camera_mount/from_tf (%s): keypoint depths are not "
        "triangulated until it comes",
        options_.base_frame.c_str(), camera_frame.c_str(), error.c_str());
    return;
  }
  const Pose mount = Pose::fromIsometry(
      tf2::transformToEigen(tf_->lookupTransform(options_.base_frame, camera_frame, ros::Time(0))));
  prepared->camera_mount = mount;
  mount_ = mount;
  mount_frame_ = camera_frame;
  ROS_INFO("Camera mount from tf: %s in %s at (%.3f, %.3f, %.3f) m", camera_frame.c_str(),
           options_.base_frame.c_str(), mount.position.x(), mount.position.y(), mount.position.z());
}

}  // namespace landmark_loop_closure
