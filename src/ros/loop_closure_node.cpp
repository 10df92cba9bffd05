#include "loop_closure_node.h"

#include <chrono>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include <cv_bridge/cv_bridge.h>
#include <image_transport/camera_common.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopCandidateArray.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/core/match_image.h"
#include "landmark_loop_closure/descriptors/landmarks.h"
#include "landmark_loop_closure/geometry/metric_pose.h"
#include "messages/ros_conversions.h"
#include "ros_parameter_source.h"

namespace landmark_loop_closure {

namespace {

constexpr double kRejectionLogPeriod = 5.0;  // Seconds between log lines for one kind of error.
constexpr size_t kMaxPendingTf = 100;
constexpr double kTfRetryPeriod = 0.02;
constexpr double kDiagnosticsPeriod = 1.0;
constexpr size_t kMaxBufferedDepths = 30;
constexpr double kDepthWait = 0.2;  // Seconds the worker waits for a keyframe's depth image.
constexpr double kDepthPollPeriod = 0.005;
constexpr double kDepthSilence = 1.0;  // Seconds of stamps without depth: the stream stopped.

}  // namespace

double LoopClosureNode::wallNow() { return ros::WallTime::now().toSec(); }

NodeOptions loadNodeOptions(const ros::NodeHandle& private_node) {
  const RosParameterSource source(private_node);
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  for (const std::string& key : source.keys()) {
    if (!reader.isKnown(key)) {
      ROS_WARN("Unknown parameter %s/%s is ignored (misspelt? see config/default.yaml)",
               private_node.getNamespace().c_str(), key.c_str());
    }
  }
  const std::string problems = reader.errors() + options.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  return options;
}

LoopClosureNode::LoopClosureNode(ros::NodeHandle node, ros::NodeHandle private_node,
                                 const NodeOptions& options)
    : node_(node),
      private_node_(private_node),
      options_(options),
      detector_(options.detector, needsOnlineTraining(options.detector.descriptor)
                                      ? nullptr
                                      : makeDescriptorExtractor(options.detector.descriptor)),
      image_transport_(node),
      markers_(options.odom_frame, options.detector.acceptance.min_score,
               options.publish_rejected_markers),
      diagnostics_(node, private_node, ros::this_node::getName()) {
  loop_publisher_ = node_.advertise<LoopClosure>("loop_closures", 100);
  keyframe_publisher_ =
      node_.advertise<Keyframe>("keyframes", 1000);  // Bursts after online training.
  candidates_publisher_ = private_node_.advertise<LoopCandidateArray>("candidates", 10);
  markers_publisher_ = private_node_.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  image_transport::ImageTransport private_transport(private_node_);
  match_image_publisher_ = private_transport.advertise("match_image", 1);

  diagnostics_.setHardwareID("none");
  diagnostics_.add("loop closure", this, &LoopClosureNode::produceDiagnostics);
  last_rate_time_ = ros::WallTime::now();
  last_paired_wall_ = wallNow();  // Inputs get input_timeout to pair before a warning.
  diagnostics_timer_ =
      node_.createWallTimer(ros::WallDuration(kDiagnosticsPeriod),
                            [this](const ros::WallTimerEvent&) { diagnostics_.force_update(); });

  // Until tf gives the mount, the configured one is not trusted for triangulation.
  if (options_.camera_mount_from_tf) detector_.setCameraMount(std::nullopt);
  if (!options_.database_path.empty() && options_.autoload &&
      std::filesystem::exists(options_.database_path)) {
    // Refusing to start keeps a file that cannot be read from being overwritten by the next save.
    const auto load_start = std::chrono::steady_clock::now();
    const std::string error = detector_.loadDatabase(options_.database_path);
    const double load_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    if (!error.empty()) {
      throw std::runtime_error(error + " (move the file away or set autoload false)");
    }
    database_status_ = "loaded " + options_.database_path;
    session_ = detector_.session();
    ROS_INFO("Loaded %zu keyframes from %s in %.2f s; this run is session %u",
             detector_.database().size(), options_.database_path.c_str(), load_s,
             detector_.session());
  }
  RuntimeOptions runtime_options;
  runtime_options.queue_size = static_cast<size_t>(options_.worker_queue_size);
  runtime_options.time_jump_back =
      options_.time_jump_back == "reset" ? TimeJumpPolicy::kReset : TimeJumpPolicy::kDrop;
  runtime_options.time_jump_back_s = options_.time_jump_back_s;
  RuntimeListener listener;
  listener.prepare = [this](const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                            InputError* error) {
    return prepareKeyframe(job, colour, prepared, error);
  };
  listener.rejected = [this](const InputError& error) { reportRejected(error); };
  listener.timeline_reset = [this] { onTimelineReset(); };
  listener.held = [this](const KeyframeJob& job, const KeyframeResult& result) {
    onHeldForTraining(job, result);
  };
  listener.training_finished = [this](const KeyframeJob& job, const KeyframeResult& result,
                                      const std::vector<ReleasedKeyframe>& held) {
    publishHeldKeyframes(nodeKeyframe(job), result, held);
  };
  listener.keyframe = [this](const KeyframeJob& job, const KeyframeResult& result,
                             const PreparedKeyframe& prepared) {
    onKeyframeDone(job, result, prepared);
  };
  runtime_ = std::make_unique<DetectorRuntime>(&detector_, runtime_options, std::move(listener));
  advertiseServices();
  subscribe();
  const std::string descriptor =
      detector_.extractor()
          ? detector_.extractor()->name()
          : "broad (trained on the first " +
                std::to_string(options_.detector.descriptor.broad.online_training_keyframes) +
                " keyframes, then written to " + options_.detector.descriptor.broad.model + ")";
  ROS_INFO("Loop closure (%s): descriptor %s, pose from %s, listening on %s%s%s",
           toString(detector_.mode()), descriptor.c_str(), options_.pose_source.c_str(),
           image_topic_.c_str(), odom_topic_.empty() ? "" : " and ", odom_topic_.c_str());
  if (!options_.fallback_warning.empty()) ROS_WARN("%s", options_.fallback_warning.c_str());
  if (detector_.mode() == DetectorMode::kLocalization && detector_.database().empty()) {
    ROS_WARN(
        "mode is localization but the keyframe database is empty: nothing will be found "
        "and nothing is added");
  }
}

LoopClosureNode::~LoopClosureNode() {
  if (service_spinner_) service_spinner_->stop();
  runtime_->stop();
  if (options_.save_on_shutdown && !options_.database_path.empty()) {
    runtime_->withDetector([this](LoopDetector& detector) {
      const std::string error = saveDatabase("");
      if (error.empty()) {
        ROS_INFO("Saved %zu keyframes to %s", detector.database().size(),
                 options_.database_path.c_str());
      } else {
        ROS_ERROR("Could not save the keyframe database at shutdown: %s", error.c_str());
      }
      return false;
    });
  }
}

void LoopClosureNode::subscribe() {
  // Never lazy: a detector that stops listening loses keyframes for good.
  image_topic_ = node_.resolveName("image");
  camera_info_subscriber_ = node_.subscribe(image_transport::getCameraInfoTopic(image_topic_), 1,
                                            &LoopClosureNode::onCameraInfo, this);
  if (options_.use_depth) {
    depth_subscriber_ = image_transport_.subscribe("depth", 5, &LoopClosureNode::onDepth, this);
  }
  if (options_.pose_source == "tf" || options_.camera_mount_from_tf) {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, node_);
  }
  if (options_.pose_source == "tf") {
    image_subscriber_ =
        image_transport_.subscribe("image", 5, &LoopClosureNode::onImageForTf, this);
    tf_timer_ = node_.createWallTimer(ros::WallDuration(kTfRetryPeriod),
                                      [this](const ros::WallTimerEvent&) { retryPendingTf(); });
    return;
  }
  odom_topic_ = node_.resolveName("odom");
  const uint32_t queue = static_cast<uint32_t>(options_.sync_queue_size);
  image_filter_.subscribe(image_transport_, "image", queue);
  odom_filter_.subscribe(node_, "odom", queue);
  image_filter_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& image) {
        ++images_received_;
        last_image_wall_ = wallNow();
        newest_image_stamp_ = image->header.stamp.toSec();
      }));
  odom_filter_.registerCallback(boost::function<void(const nav_msgs::OdometryConstPtr&)>(
      [this](const nav_msgs::OdometryConstPtr& odometry) {
        ++odometry_received_;
        last_odometry_wall_ = wallNow();
        newest_odometry_stamp_ = odometry->header.stamp.toSec();
      }));
  sync_ = std::make_unique<message_filters::Synchronizer<SyncPolicy>>(SyncPolicy(queue),
                                                                      image_filter_, odom_filter_);
  sync_->setMaxIntervalDuration(ros::Duration(options_.sync_slop));
  sync_->registerCallback(boost::bind(&LoopClosureNode::onImageWithOdometry, this,
                                      boost::placeholders::_1, boost::placeholders::_2));
}

void LoopClosureNode::onImageWithOdometry(const sensor_msgs::ImageConstPtr& image,
                                          const nav_msgs::OdometryConstPtr& odometry) {
  last_paired_wall_ = wallNow();
  const std::string& frame =
      odometry->header.frame_id.empty() ? options_.odom_frame : odometry->header.frame_id;
  admitFrame(image, fromRos(odometry->pose.pose), frame);
}

void LoopClosureNode::onImageForTf(const sensor_msgs::ImageConstPtr& image) {
  ++images_received_;
  last_image_wall_ = wallNow();
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
      last_odometry_wall_ = wallNow();
      ++odometry_received_;
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
  std::lock_guard<std::mutex> lock(stats_mutex_);
  camera_info_ = info;
  camera_info_seen_ = true;
}

void LoopClosureNode::onDepth(const sensor_msgs::ImageConstPtr& depth) {
  std::lock_guard<std::mutex> lock(depth_mutex_);
  depth_buffer_.push_back(depth);
  if (depth_buffer_.size() > kMaxBufferedDepths) depth_buffer_.pop_front();
}

void LoopClosureNode::admitFrame(const sensor_msgs::ImageConstPtr& image, const Pose& pose,
                                 const std::string& frame_id) {
  if (auto error = checkImageMessage(*image)) {
    reportRejected(*error);
    return;
  }
  FrameInput frame;
  frame.stamp = toSeconds(image->header.stamp);
  frame.pose = pose;
  frame.width = static_cast<int>(image->width);
  frame.height = static_cast<int>(image->height);
  frame.cv_type = *cvTypeOfEncoding(image->encoding);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (camera_info_) frame.intrinsics = fromCameraInfo(*camera_info_);
  }
  frame.source = FrameSource{image, frame_id};
  const RuntimeAdmission admitted = runtime_->admit(std::move(frame));
  if (admitted.timeline_restarted_after_s) {
    ROS_WARN(
        "Time went back %.2f s (bag restarted or simulated clock reset): forgetting every "
        "keyframe and starting over (time_jump_back: reset)",
        *admitted.timeline_restarted_after_s);
  }
  const FrameAdmission& admission = admitted.admission;
  if (admission.error) {
    reportRejected(*admission.error);
    return;
  }
  ++frames_admitted_;
  const Selection& selection = admission.selection;
  if (selection.verdict == SelectionVerdict::kOdometryJump) {
    ++odometry_jumps_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Odometry jumped: motion %.2f since the last keyframe exceeds "
                      "keyframe/max_motion %.2f; frame refused (tracking lost?)",
                      selection.motion, options_.detector.keyframe.max_motion);
    return;
  }
  if (selection.reanchored) {
    ROS_WARN(
        "Odometry stayed %.2f away from the last keyframe for %d frames: taking it as "
        "re-initialised and starting from keyframe %lu",
        selection.motion, options_.detector.keyframe.jump_reanchor_frames,
        static_cast<unsigned long>(admission.keyframe_id));
  }
  if (admitted.dropped_oldest) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Worker cannot keep up: dropped the oldest queued keyframe (%lu dropped so "
                      "far); raise worker_queue_size or keyframe/min_motion",
                      static_cast<unsigned long>(runtime_->keyframesDropped()));
  }
}

void LoopClosureNode::reportRejected(const InputError& error) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++rejected_[error.code];
  const ros::WallTime now = ros::WallTime::now();
  auto last = last_rejection_log_.find(error.code);
  if (last != last_rejection_log_.end() && (now - last->second).toSec() < kRejectionLogPeriod) {
    return;
  }
  last_rejection_log_[error.code] = now;
  ROS_ERROR("Dropped frame (%s, %lu so far): %s", toString(error.code),
            static_cast<unsigned long>(rejected_[error.code]), error.message.c_str());
}

LoopClosureNode::NodeKeyframe LoopClosureNode::nodeKeyframe(const KeyframeJob& job) {
  const auto& source = std::any_cast<const FrameSource&>(job.source);
  return {source.image, job.id, source.image->header.stamp, job.pose, source.frame_id};
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
  if (options_.camera_mount_from_tf) updateCameraMount(camera_frame);
  if (options_.use_depth) {
    prepared->depth = depthFor(source.image->header.stamp, camera_frame);
    ++(prepared->depth.empty() ? keyframes_without_depth_ : keyframes_with_depth_);
  }
  return true;
}

void LoopClosureNode::onTimelineReset() {
  session_ = detector_.session();
  keyframe_stamps_.clear();
  markers_.clear();
}

void LoopClosureNode::onHeldForTraining(const KeyframeJob& job, const KeyframeResult& result) {
  keyframe_stamps_[job.id] = nodeKeyframe(job).stamp;
  ROS_INFO_THROTTLE(
      kWarningPeriod, "Holding keyframes for the broad autoencoder's training: %d of %d",
      result.held_for_training, options_.detector.descriptor.broad.online_training_keyframes);
}

void LoopClosureNode::onKeyframeDone(const KeyframeJob& job, const KeyframeResult& result,
                                     const PreparedKeyframe& prepared) {
  const NodeKeyframe keyframe = nodeKeyframe(job);
  ++keyframes_stored_;
  if (!result.stored && detector_.mode() == DetectorMode::kMapping) {
    ++keyframes_over_budget_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Database memory budget of %.0f MB reached (%zu keyframes): keyframes are "
                      "searched for loops but no longer stored",
                      options_.detector.database.memory_budget_mb, detector_.database().size());
  }
  keyframe_stamps_[job.id] = keyframe.stamp;
  publishResults(keyframe, result, prepared.grey);
  if (options_.autosave_every > 0 && !options_.database_path.empty() &&
      detector_.mode() == DetectorMode::kMapping &&
      ++stored_since_save_ >= options_.autosave_every) {
    const std::string error = saveDatabase("");
    if (!error.empty()) ROS_ERROR_THROTTLE(kWarningPeriod, "Autosave failed: %s", error.c_str());
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  database_bytes_ = detector_.database().bytes();
}

cv::Mat LoopClosureNode::depthFor(const ros::Time& stamp, const std::string& camera_frame) {
  const ros::Duration slop(options_.sync_slop);
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(kDepthWait);
  sensor_msgs::ImageConstPtr nearest;
  while (true) {
    bool later_arrived = false;
    bool stream_alive = false;
    {
      std::lock_guard<std::mutex> lock(depth_mutex_);
      // Waiting only helps while depth comes: none for a second before this keyframe, or nobody
      // publishing it, and waiting would only slow the worker down.
      stream_alive =
          depth_buffer_.empty()
              ? depth_subscriber_.getNumPublishers() > 0
              : depth_buffer_.back()->header.stamp + ros::Duration(kDepthSilence) > stamp;
      const auto gap = [&stamp](const sensor_msgs::ImageConstPtr& depth) {
        const ros::Time& other = depth->header.stamp;
        return other > stamp ? other - stamp : stamp - other;
      };
      for (const sensor_msgs::ImageConstPtr& candidate : depth_buffer_) {
        later_arrived |= candidate->header.stamp > stamp + slop;
        if (gap(candidate) <= slop && (!nearest || gap(candidate) < gap(nearest))) {
          nearest = candidate;
        }
      }
    }
    // A depth image newer than the slop means the matching one will not come any more.
    if (nearest || later_arrived || !stream_alive || ros::WallTime::now() > give_up || !ros::ok()) {
      break;
    }
    ros::WallDuration(kDepthPollPeriod).sleep();
  }
  if (!nearest) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "No depth image within sync_slop %.3f s of the keyframe at %.3f: its "
                      "keypoint depths are triangulated instead (if enabled)",
                      options_.sync_slop, stamp.toSec());
    return {};
  }
  std::string error;
  cv::Mat depth = toDepth(*nearest, &error);
  if (!error.empty()) {
    ROS_WARN_THROTTLE(kWarningPeriod, "Depth image at %.3f not used: %s",
                      nearest->header.stamp.toSec(), error.c_str());
    return {};
  }
  // Depth from another camera's frame would put every point in the wrong place.
  if (nearest->header.frame_id != camera_frame) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Depth image not used: its frame '%s' is not the image's '%s' (subscribe to "
                      "a depth topic registered to the image)",
                      nearest->header.frame_id.c_str(), camera_frame.c_str());
    return {};
  }
  return depth;
}

void LoopClosureNode::updateCameraMount(const std::string& camera_frame) {
  if (camera_frame == camera_mount_frame_ && detector_.cameraMount()) return;
  if (camera_frame.empty()) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Images carry no frame_id, so camera_mount/from_tf cannot look the camera "
                      "up in tf: keypoint depths are not triangulated");
    return;
  }
  std::string error;
  if (!tf_buffer_->canTransform(options_.base_frame, camera_frame, ros::Time(0), &error)) {
    detector_.setCameraMount(std::nullopt);
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "No tf %s -> %s yet for camera_mount/from_tf (%s): keypoint depths are not "
                      "triangulated until it comes",
                      options_.base_frame.c_str(), camera_frame.c_str(), error.c_str());
    return;
  }
  const Pose mount = Pose::fromIsometry(tf2::transformToEigen(
      tf_buffer_->lookupTransform(options_.base_frame, camera_frame, ros::Time(0))));
  detector_.setCameraMount(mount);
  camera_mount_frame_ = camera_frame;
  ROS_INFO("Camera mount from tf: %s in %s at (%.3f, %.3f, %.3f) m", camera_frame.c_str(),
           options_.base_frame.c_str(), mount.position.x(), mount.position.y(), mount.position.z());
}

std::string LoopClosureNode::expressRelativePose(AcceptedLoop* loop,
                                                 const std::string& camera_frame) const {
  if (options_.relative_pose_frame != "base" || !loop->relative_pose ||
      !loop->relative_pose->metric) {
    return camera_frame;
  }
  const std::optional<Pose>& mount = detector_.cameraMount();
  if (!mount) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Relative pose left in the camera frame %s: the camera mount is not known "
                      "yet (camera_mount/from_tf)",
                      camera_frame.c_str());
    return camera_frame;
  }
  loop->relative_pose = inBodyFrame(*loop->relative_pose, *mount);
  return options_.base_frame;
}

void LoopClosureNode::publishResults(const NodeKeyframe& job, const KeyframeResult& result,
                                     const cv::Mat& grey) {
  keyframe_publisher_.publish(
      toKeyframeMsg(job.id, detector_.session(), job.stamp, job.pose, job.frame_id));
  if (result.loop) {
    AcceptedLoop loop = *result.loop;
    const std::string pose_frame = expressRelativePose(&loop, job.image->header.frame_id);
    loop_publisher_.publish(
        toLoopMsg(loop, job.stamp, stampOf(loop.match_id), job.frame_id, pose_frame));
    ++loops_published_;
    ROS_INFO("Loop: keyframe %lu matches keyframe %lu (score %.3f, %d consistent keyframes)",
             static_cast<unsigned long>(result.loop->query_id),
             static_cast<unsigned long>(result.loop->match_id), result.loop->score,
             result.loop->consistent_keyframes);
  }
  if (candidates_publisher_.getNumSubscribers() > 0) {
    candidates_publisher_.publish(toCandidatesMsg(result, job.stamp, job.frame_id,
                                                  [this](uint64_t id) { return stampOf(id); }));
  }

  markers_.setFrameId(job.frame_id);
  markers_.addKeyframe(job.pose);
  // A loop into an earlier session joins two odometry frames: no line can be drawn in this one.
  if (result.loop && result.loop->match_session == result.loop->query_session) {
    markers_.addLoop(*result.loop);
  }
  for (const CandidateReport& candidate : result.candidates) {
    if (candidate.verdict != CandidateVerdict::kAwaitingConsistency &&
        candidate.verdict != CandidateVerdict::kOutscored &&
        candidate.verdict != CandidateVerdict::kOdometryRejected) {
      continue;
    }
    const KeyframeRecord* match = detector_.database().findById(candidate.match_id);
    if (match && match->session == detector_.session()) {
      markers_.addRejected(job.pose, match->pose);
    }
  }
  if (markers_publisher_.getNumSubscribers() > 0) {
    markers_publisher_.publish(markers_.toMsg(job.stamp));
  }
  if (match_image_publisher_.getNumSubscribers() > 0) publishMatchImage(job, result, grey);
}

void LoopClosureNode::publishMatchImage(const NodeKeyframe& job, const KeyframeResult& result,
                                        const cv::Mat& grey) {
  if (result.candidates.empty()) return;
  const CandidateReport& best = result.candidates.front();
  const KeyframeRecord* match = detector_.database().findById(best.match_id);
  std::ostringstream caption;
  caption.precision(3);
  caption << "keyframe " << result.keyframe_id << " vs " << best.match_id << "  score "
          << std::fixed << best.score << "  " << toString(best.verdict);
  if (!best.detail.empty()) caption << ": " << best.detail;
  if (result.loop && result.loop->verification) {
    caption << "  " << result.loop->verification->inliers << " inliers";
  }
  // The stored query keyframe: its thumbnail shares the landmark boxes' 160x120 frame.
  const KeyframeRecord* query = detector_.database().findById(result.keyframe_id);
  const cv::Mat query_thumbnail = query ? decodeThumbnail(query->thumbnail_jpeg) : cv::Mat();
  const cv::Mat match_thumbnail = match ? decodeThumbnail(match->thumbnail_jpeg) : cv::Mat();
  std::vector<std::pair<cv::Rect2f, cv::Rect2f>> landmark_pairs;
  std::vector<std::pair<cv::Point2f, cv::Point2f>> inlier_pairs;
  if (query && match && !query_thumbnail.empty()) {
    for (const LandmarkMatch& pair :
         matchLandmarks(query->descriptor.landmark_features, match->descriptor.landmark_features)) {
      landmark_pairs.emplace_back(query->descriptor.landmark_boxes[pair.a],
                                  match->descriptor.landmark_boxes[pair.b]);
    }
    if (result.loop && result.loop->match_id == match->id && result.loop->verification &&
        query->local_features.image_size.width > 0) {
      const float scale =
          static_cast<float>(query_thumbnail.cols) / query->local_features.image_size.width;
      for (const auto& [q, m] : result.loop->verification->inlier_pairs) {
        inlier_pairs.emplace_back(q * scale, m * scale);
      }
    }
  }
  const cv::Mat& query_picture = query_thumbnail.empty() ? grey : query_thumbnail;
  const cv::Mat picture = renderMatchImage(query_picture, match_thumbnail, caption.str(),
                                           best.verdict == CandidateVerdict::kAccepted, 240,
                                           landmark_pairs, inlier_pairs);
  std_msgs::Header header;
  header.stamp = job.stamp;
  match_image_publisher_.publish(cv_bridge::CvImage(header, "bgr8", picture).toImageMsg());
}

}  // namespace landmark_loop_closure
