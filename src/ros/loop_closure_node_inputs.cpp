// The node's inputs: image/odometry pairs or tf lookups, camera_info and depth, admitted into the
// runtime; on the worker, a keyframe's images and depth prepared for the detector.
#include "loop_closure_node.h"

#include <cv_bridge/cv_bridge.h>
#include <tf2_eigen/tf2_eigen.h>

#include "landmark_loop_closure/geometry/metric_pose.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxPendingTf = 100;
constexpr double kDepthWait = 0.2;     // Seconds the worker waits for a keyframe's depth image.
constexpr double kDepthSilence = 1.0;  // Seconds of stamps without depth: the stream stopped.

}  // namespace

void LoopClosureNode::onImageForOdometry(const sensor_msgs::ImageConstPtr& image) {
  inputs_.imageArrived(wallNow(), image->header.stamp.toSec());
  pending_odometry_.push_back(image);
  if (pending_odometry_.size() > static_cast<size_t>(options_.sync_queue_size)) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Dropped image at %.3f: %d images wait for odometry after their stamps "
                      "(advanced/sync_queue_size), the newest odometry is at %.3f",
                      pending_odometry_.front()->header.stamp.toSec(), options_.sync_queue_size,
                      odometry_history_.newest());
    pending_odometry_.pop_front();
  }
  pairPendingWithOdometry();
}

std::optional<Pose> LoopClosureNode::bodyPose(const nav_msgs::Odometry& odometry) {
  const Pose pose = fromRos(odometry.pose.pose);
  const std::string& child = odometry.child_frame_id;
  if (child.empty() || child == options_.base_frame || options_.base_frame.empty()) return pose;
  if (!tf_buffer_) {  // Made when first needed: most odometry is already of base_frame.
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, node_);
  }
  Eigen::Isometry3d child_from_base;
  try {
    child_from_base = tf2::transformToEigen(
        tf_buffer_->lookupTransform(child, options_.base_frame, ros::Time(0)));
  } catch (const tf2::TransformException& error) {
    ROS_ERROR_THROTTLE(kWarningPeriod,
                       "Odometry is of child_frame_id '%s', not base_frame '%s', and tf has no "
                       "transform between them yet (%s): odometry dropped until it has",
                       child.c_str(), options_.base_frame.c_str(), error.what());
    return std::nullopt;
  }
  ROS_INFO_ONCE("Odometry is of child_frame_id '%s': turned into base_frame '%s' through tf",
                child.c_str(), options_.base_frame.c_str());
  return Pose::fromIsometry(pose.toIsometry() * child_from_base);
}

void LoopClosureNode::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const double stamp = odometry->header.stamp.toSec();
  inputs_.poseArrived(wallNow(), stamp);
  const std::optional<Pose> pose = bodyPose(*odometry);
  if (!pose) return;
  odometry_frame_ =
      odometry->header.frame_id.empty() ? options_.odom_frame : odometry->header.frame_id;
  const double newest_before = odometry_history_.newest();
  if (odometry_history_.add(stamp, *pose)) {
    // Images of the old timeline would wait for odometry that never comes.
    const size_t held = pending_odometry_.size();
    while (!pending_odometry_.empty() &&
           pending_odometry_.front()->header.stamp.toSec() > stamp + options_.time_jump_back_s) {
      pending_odometry_.pop_front();
    }
    ROS_WARN("Odometry jumped back from %.3f to %.3f: the earlier odometry is forgotten%s",
             newest_before, stamp,
             held > pending_odometry_.size() ? ", and the images waiting for it dropped" : "");
  }
  pairPendingWithOdometry();
}

void LoopClosureNode::pairPendingWithOdometry() {
  while (!pending_odometry_.empty()) {
    const sensor_msgs::ImageConstPtr image = pending_odometry_.front();
    const double stamp = image->header.stamp.toSec();
    const OdometryLookup lookup = odometry_history_.at(stamp, options_.odometry_max_interval);
    if (lookup.status == OdometryAt::kNotYet || lookup.status == OdometryAt::kNoOdometry) return;
    pending_odometry_.pop_front();
    if (lookup.status == OdometryAt::kFound) {
      inputs_.paired(wallNow());
      // The odometry between the last keyframe and this image, so that a camera gap while the
      // robot drives on is not taken for a reset.
      admitFrame(image, lookup.pose, odometry_frame_, [this, stamp](double since) {
        return odometry_history_.posesBetween(since, stamp, options_.odometry_max_interval);
      });
      continue;
    }
    if (lookup.status == OdometryAt::kGapTooLong) {
      ROS_WARN_THROTTLE(kWarningPeriod,
                        "Dropped image at %.3f: the odometry messages around it are %.3f s "
                        "apart, more than advanced/odometry_max_interval %.3f",
                        stamp, lookup.interval, options_.odometry_max_interval);
    } else {
      ROS_WARN_THROTTLE(kWarningPeriod,
                        "Dropped image at %.3f: it is older than every odometry message held "
                        "(%zu, from the newest at %.3f back)",
                        stamp, odometry_history_.size(), odometry_history_.newest());
    }
  }
}

void LoopClosureNode::onImageForTf(const sensor_msgs::ImageConstPtr& image) {
  inputs_.imageArrived(wallNow(), image->header.stamp.toSec());
  pending_tf_.push_back({image, ros::WallTime::now()});
  if (pending_tf_.size() > kMaxPendingTf) {
    pending_tf_.pop_front();
    ++tf_timeouts_;
  }
  retryPendingTf();
}

void LoopClosureNode::retryPendingTf() {
  while (!pending_tf_.empty()) {
    const PendingImage& pending = pending_tf_.front();
    const ros::Time stamp = pending.image->header.stamp;
    std::string error;
    if (tf_buffer_->canTransform(options_.odom_frame, options_.base_frame, stamp, &error)) {
      const geometry_msgs::TransformStamped transform =
          tf_buffer_->lookupTransform(options_.odom_frame, options_.base_frame, stamp);
      inputs_.poseArrived(wallNow(), stamp.toSec());
      const Pose pose = Pose::fromIsometry(tf2::transformToEigen(transform));
      const sensor_msgs::ImageConstPtr image = pending.image;
      pending_tf_.pop_front();
      admitFrame(image, pose, options_.odom_frame);
      continue;
    }
    if ((ros::WallTime::now() - pending.received).toSec() < options_.tf_timeout) return;
    ++tf_timeouts_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Dropped image at %.3f: no transform %s -> %s after %.2f s (%s)",
                      stamp.toSec(), options_.odom_frame.c_str(), options_.base_frame.c_str(),
                      options_.tf_timeout, error.c_str());
    pending_tf_.pop_front();
  }
}

void LoopClosureNode::onCameraInfo(const sensor_msgs::CameraInfoConstPtr& info) {
  MutexLock lock(stats_mutex_);
  // Converted once, not on every image.
  camera_intrinsics_ = fromCameraInfo(*info, options_.images_rectified);
  camera_info_seen_ = true;
}

void LoopClosureNode::onDepth(const sensor_msgs::ImageConstPtr& depth) {
  depth_buffer_.push(depth->header.stamp.toSec(), depth);
  if (depth_silence_reported_.exchange(false)) {
    ROS_INFO("Depth images arrive on %s again", depth_subscriber_.getTopic().c_str());
  }
}

void LoopClosureNode::admitFrame(const sensor_msgs::ImageConstPtr& image, const Pose& pose,
                                 const std::string& frame_id, OdometrySince odometry_since) {
  if (auto error = checkImageMessage(*image)) {
    reportRejected(*error);
    return;
  }
  FrameInput frame;
  frame.stamp = toSeconds(image->header.stamp);
  frame.stamp_ns = static_cast<int64_t>(image->header.stamp.toNSec());
  frame.pose = pose;
  frame.width = static_cast<int>(image->width);
  frame.height = static_cast<int>(image->height);
  frame.cv_type = *cvTypeOfEncoding(image->encoding);
  frame.clock = ros::Time::now().toSec();
  std::optional<CalibrationProblem> calibration_problem;
  {
    MutexLock lock(stats_mutex_);
    frame.intrinsics = camera_intrinsics_;
    if (camera_info_seen_) {
      calibration_problem = frame.intrinsics.checkFor(cv::Size(frame.width, frame.height));
      if (calibration_problem) frame.intrinsics = CameraIntrinsics();
    }
  }
  frame.source = FrameSource{image, frame_id};
  frame.odometry_since = std::move(odometry_since);
  const double frame_stamp = frame.stamp;
  const RuntimeAdmission admitted = runtime_->admit(std::move(frame));
  if (admitted.timeline_restarted_after_s) {
    ROS_WARN(
        "Time went back %.2f s (bag restarted or simulated clock reset): forgetting every "
        "keyframe and starting over (advanced/time_jump_back: reset)",
        *admitted.timeline_restarted_after_s);
  }
  if (admitted.time_jump_after_frames_s) {
    last_time_jump_wall_ = wallNow();
    ROS_WARN(
        "Time jump: %d frames in a row were stamped before the last keyframe (%.2f s after this "
        "frame's %.3f s); %s",
        options_.time_jump_frames, *admitted.time_jump_after_frames_s, frame_stamp,
        admitted.map_forgotten ? "forgetting every keyframe and starting over from this frame "
                                 "(advanced/time_jump_back: reset)"
                               : "starting a new timeline from this frame, the map kept "
                                 "(advanced/time_jump_back: drop)");
  }
  const FrameAdmission& admission = admitted.admission;
  if (admission.error) {
    reportRejected(*admission.error);
    return;
  }
  ++frames_admitted_;
  // The worker may reach this keyframe after its depth image left the buffer's window.
  if (options_.use_depth && admission.isKeyframe()) {
    depth_buffer_.want(frame_stamp, options_.sync_slop);
  }
  if (!descriptor_path_said_) sayDescriptorPath(cv::Size(image->width, image->height));
  noteCalibration(calibration_problem);
  const Selection& selection = admission.selection;
  if (selection.verdict == SelectionVerdict::kOdometryJump) {
    ++odometry_jumps_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Odometry jumped: motion %.2f since the last keyframe exceeds "
                      "advanced/keyframe/max_motion %.2f; frame refused (tracking lost?)",
                      selection.motion, options_.detector.keyframe.max_motion);
    return;
  }
  if (selection.across_gap) {
    ROS_INFO_THROTTLE(kWarningPeriod,
                      "Keyframe %lu after a camera gap: motion %.2f since the last keyframe, the "
                      "odometry continuous all the way (the same session)",
                      static_cast<unsigned long>(admission.keyframe_id), selection.motion);
  }
  if (selection.reanchored) {
    ROS_WARN(
        "Odometry stayed %.2f away from the last keyframe for %d frames: taking it as "
        "re-initialised and starting from keyframe %lu, the first of a new session (another "
        "odometry frame)",
        selection.motion, options_.detector.keyframe.jump_reanchor_frames,
        static_cast<unsigned long>(admission.keyframe_id));
  }
  if (admitted.dropped_oldest) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Worker cannot keep up: dropped the oldest queued keyframe (%lu dropped so "
                      "far); raise advanced/worker_queue_size or advanced/keyframe/min_motion",
                      static_cast<unsigned long>(runtime_->keyframesDropped()));
  }
}

void LoopClosureNode::sayDescriptorPath(cv::Size image_size) {
  // Only when the detector is free (never waits on the worker): a later image says it otherwise.
  std::string text;
  if (!runtime_->tryWithDetector([&](LoopDetector& detector) {
        text = detector.extractor()->describesAs(image_size);
        return false;
      }) ||
      text.empty()) {
    return;
  }
  if (descriptor_path_said_.exchange(true)) return;  // Another callback said it meanwhile.
  ROS_INFO("Descriptor %s", text.c_str());
}

void LoopClosureNode::noteCalibration(const std::optional<CalibrationProblem>& problem) {
  // Only frames the runtime accepted judge camera_info: a dropped 1x1 image says nothing about it.
  // Unusable calibration turns the geometric check off: said once per period and cause, and in
  // the diagnostics and every loop's log line, instead of silently.
  MutexLock lock(stats_mutex_);
  if (!camera_info_seen_) return;
  camera_info_problem_ = problem ? problem->text : "";
  if (problem && camera_info_warnings_.allow(problem->cause, ros::WallTime::now().toSec())) {
    ROS_WARN("camera_info not used, the geometric check is off (%s): %s", problem->cause.c_str(),
             problem->text.c_str());
  }
}

void LoopClosureNode::reportRejected(const InputError& error) {
  uint64_t count = 0;
  if (!inputs_.rejected(error.code, wallNow(), &count)) return;
  ROS_ERROR("Dropped frame (%s, %lu so far): %s", toString(error.code),
            static_cast<unsigned long>(count), error.message.c_str());
}

bool LoopClosureNode::prepareKeyframe(const KeyframeJob& job, bool colour,
                                      PreparedKeyframe* prepared, InputError* error) {
  const auto& source = std::any_cast<const FrameSource&>(job.source);
  try {
    prepared->grey = toGrey(*source.image);
    prepared->image = colour ? toBgr(*source.image) : prepared->grey;
  } catch (const cv::Exception& exception) {
    *error = {InputErrorCode::kUnsupportedImageType, exception.what()};
    return false;
  }
  const std::string& camera_frame = source.image->header.frame_id;
  if (options_.camera_mount_from_tf || options_.mountFromTfWhereKnown()) {
    updateCameraMount(camera_frame, prepared);
  }
  if (options_.use_depth) {
    prepared->depth = depthFor(source.image->header.stamp, camera_frame);
    ++(prepared->depth.empty() ? keyframes_without_depth_ : keyframes_with_depth_);
  }
  return true;
}

cv::Mat LoopClosureNode::depthFor(const ros::Time& stamp, const std::string& camera_frame) {
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

void LoopClosureNode::updateCameraMount(const std::string& camera_frame,
                                        PreparedKeyframe* prepared) {
  if (!camera_mount_frame_.empty() && camera_frame == camera_mount_frame_ &&
      detector_.cameraMount()) {
    return;
  }
  if (!options_.camera_mount_from_tf) {
    // No value set: tf's mount where tf has it, else the default values, said once.
    std::string error;
    if (camera_frame.empty() ||
        !tf_buffer_->canTransform(options_.base_frame, camera_frame, ros::Time(0), &error)) {
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
  if (!tf_buffer_->canTransform(options_.base_frame, camera_frame, ros::Time(0), &error)) {
    prepared->camera_mount = std::optional<Pose>();
    ROS_WARN_THROTTLE(
        kWarningPeriod,
        "No tf %s -> %s yet for advanced/camera_mount/from_tf (%s): keypoint depths are not "
        "triangulated until it comes",
        options_.base_frame.c_str(), camera_frame.c_str(), error.c_str());
    return;
  }
  const Pose mount = Pose::fromIsometry(tf2::transformToEigen(
      tf_buffer_->lookupTransform(options_.base_frame, camera_frame, ros::Time(0))));
  prepared->camera_mount = mount;
  camera_mount_frame_ = camera_frame;
  ROS_INFO("Camera mount from tf: %s in %s at (%.3f, %.3f, %.3f) m", camera_frame.c_str(),
           options_.base_frame.c_str(), mount.position.x(), mount.position.y(), mount.position.z());
}

}  // namespace landmark_loop_closure
