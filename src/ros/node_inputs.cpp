#include "node_inputs.h"

#include <image_transport/camera_common.h>
#include <tf2_eigen/tf2_eigen.h>

#include "frame_source.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxPendingTf = 100;
constexpr double kTfRetryPeriod = 0.02;

InputMonitorOptions inputMonitorOptions(const NodeOptions& options) {
  InputMonitorOptions monitor;
  monitor.timeout_s = options.input_timeout;
  monitor.max_interval_s = options.odometry_max_interval;
  return monitor;
}

bool needsTf(const NodeOptions& options) {
  return options.pose_source == PoseSource::kTf || options.camera_mount_from_tf ||
         options.mountFromTfWhereKnown();
}

}  // namespace

NodeInputs::NodeInputs(ros::NodeHandle node, const NodeOptions& options, NodeCounters* counters)
    : node_(node),
      options_(options),
      counters_(*counters),
      tf_buffer_(needsTf(options) ? std::make_unique<tf2_ros::Buffer>() : nullptr),
      tf_listener_(tf_buffer_ ? std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, node_)
                              : nullptr),
      image_transport_(node),
      odometry_history_(2000, options.time_jump_back_s),
      monitor_(inputMonitorOptions(options), ros::WallTime::now().toSec()),
      camera_info_(options.images_rectified, kWarningPeriod),
      preparation_(options, counters, tf_buffer_.get()) {}

void NodeInputs::start(DetectorRuntime* runtime) {
  runtime_ = runtime;
  image_topic_ = node_.resolveName("image");
  // camera_info remapped (the launch file's camera_info argument): that topic; else the one
  // beside the image, as image_transport's camera subscribers take it.
  const std::string remapped_info = node_.resolveName("camera_info");
  const std::string info_topic = remapped_info != node_.resolveName("camera_info", false)
                                     ? remapped_info
                                     : image_transport::getCameraInfoTopic(image_topic_);
  camera_info_subscriber_ = node_.subscribe(info_topic, 1, &NodeInputs::onCameraInfo, this);
  preparation_.subscribeDepth(&image_transport_);
  if (options_.pose_source == PoseSource::kTf) {
    image_subscriber_ = image_transport_.subscribe("image", 5, &NodeInputs::onImageForTf, this);
    tf_timer_ = node_.createWallTimer(ros::WallDuration(kTfRetryPeriod),
                                      [this](const ros::WallTimerEvent&) { retryPendingTf(); });
    return;
  }
  odom_topic_ = node_.resolveName("odom");
  const uint32_t queue = static_cast<uint32_t>(options_.sync_queue_size);
  image_subscriber_ =
      image_transport_.subscribe("image", queue, &NodeInputs::onImageForOdometry, this);
  // Odometry usually comes faster than images: enough for the images' wait.
  odom_subscriber_ = node_.subscribe("odom", 200, &NodeInputs::onOdometry, this);
}

bool NodeInputs::prepare(const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                         InputError* error) {
  const auto& source = std::any_cast<const FrameSource&>(job.source);
  return preparation_.prepare(*source.image, colour, prepared, error);
}

void NodeInputs::onImageForOdometry(const sensor_msgs::ImageConstPtr& image) {
  monitor_.imageArrived(ros::WallTime::now().toSec(), image->header.stamp.toSec());
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

std::optional<Pose> NodeInputs::bodyPose(const nav_msgs::Odometry& odometry) {
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

void NodeInputs::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const double stamp = odometry->header.stamp.toSec();
  monitor_.poseArrived(ros::WallTime::now().toSec(), stamp);
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

void NodeInputs::pairPendingWithOdometry() {
  while (!pending_odometry_.empty()) {
    const sensor_msgs::ImageConstPtr image = pending_odometry_.front();
    const double stamp = image->header.stamp.toSec();
    const OdometryLookup lookup = odometry_history_.at(stamp, options_.odometry_max_interval);
    if (lookup.status == OdometryAt::kNotYet || lookup.status == OdometryAt::kNoOdometry) return;
    pending_odometry_.pop_front();
    if (lookup.status == OdometryAt::kFound) {
      monitor_.paired(ros::WallTime::now().toSec());
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

void NodeInputs::onImageForTf(const sensor_msgs::ImageConstPtr& image) {
  monitor_.imageArrived(ros::WallTime::now().toSec(), image->header.stamp.toSec());
  pending_tf_.push_back({image, ros::WallTime::now()});
  if (pending_tf_.size() > kMaxPendingTf) {
    pending_tf_.pop_front();
    ++counters_.tf_timeouts;
  }
  retryPendingTf();
}

void NodeInputs::retryPendingTf() {
  while (!pending_tf_.empty()) {
    const PendingImage& pending = pending_tf_.front();
    const ros::Time stamp = pending.image->header.stamp;
    std::string error;
    if (tf_buffer_->canTransform(options_.odom_frame, options_.base_frame, stamp, &error)) {
      const geometry_msgs::TransformStamped transform =
          tf_buffer_->lookupTransform(options_.odom_frame, options_.base_frame, stamp);
      monitor_.poseArrived(ros::WallTime::now().toSec(), stamp.toSec());
      const Pose pose = Pose::fromIsometry(tf2::transformToEigen(transform));
      const sensor_msgs::ImageConstPtr image = pending.image;
      pending_tf_.pop_front();
      admitFrame(image, pose, options_.odom_frame);
      continue;
    }
    if ((ros::WallTime::now() - pending.received).toSec() < options_.tf_timeout) return;
    ++counters_.tf_timeouts;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Dropped image at %.3f: no transform %s -> %s after %.2f s (%s)",
                      stamp.toSec(), options_.odom_frame.c_str(), options_.base_frame.c_str(),
                      options_.tf_timeout, error.c_str());
    pending_tf_.pop_front();
  }
}

void NodeInputs::admitFrame(const sensor_msgs::ImageConstPtr& image, const Pose& pose,
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
  const CameraInfoState::ForImage calibration =
      camera_info_.forImage(cv::Size(frame.width, frame.height));
  frame.intrinsics = calibration.intrinsics;
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
    counters_.last_time_jump_wall = ros::WallTime::now().toSec();
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
  ++counters_.frames_admitted;
  if (admission.isKeyframe()) preparation_.wantDepth(frame_stamp);
  if (!descriptor_path_said_) sayDescriptorPath(cv::Size(image->width, image->height));
  camera_info_.noteAccepted(calibration.problem);
  const Selection& selection = admission.selection;
  if (selection.verdict == SelectionVerdict::kOdometryJump) {
    ++counters_.odometry_jumps;
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

void NodeInputs::sayDescriptorPath(cv::Size image_size) {
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

void NodeInputs::reportRejected(const InputError& error) {
  uint64_t count = 0;
  if (!monitor_.rejected(error.code, ros::WallTime::now().toSec(), &count)) return;
  ROS_ERROR("Dropped frame (%s, %lu so far): %s", toString(error.code),
            static_cast<unsigned long>(count), error.message.c_str());
}

}  // namespace landmark_loop_closure
