// The node's wiring: options, the detector and its runtime, subscriptions, publishers, services
// and diagnostics. Inputs are handled in loop_closure_node_inputs.cpp, results published in
// loop_closure_node_outputs.cpp.
#include "loop_closure_node.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <image_transport/camera_common.h>
#include <visualization_msgs/MarkerArray.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopCandidateArray.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "messages/ros_conversions.h"
#include "ros_parameter_source.h"

namespace landmark_loop_closure {

namespace {

constexpr double kTfRetryPeriod = 0.02;
constexpr double kDiagnosticsPeriod = 1.0;

}  // namespace

double LoopClosureNode::wallNow() { return ros::WallTime::now().toSec(); }

namespace {

// The node's last lines: ROS shut its console down before a node stopped by SIGINT is destroyed,
// so they are written to the terminal directly, in the console's format, when ROS is gone.
void logAtStop(ros::console::levels::Level level, const std::string& text) {
  const bool warn = level >= ros::console::levels::Warn;
  if (ros::ok()) {
    if (warn) {
      ROS_WARN("%s", text.c_str());
    } else {
      ROS_INFO("%s", text.c_str());
    }
    return;
  }
  std::FILE* out = warn ? stderr : stdout;
  std::fprintf(out, "[%s] [%.9f]: %s\n", warn ? " WARN" : " INFO", ros::WallTime::now().toSec(),
               text.c_str());
  std::fflush(out);
}

InputMonitorOptions inputMonitorOptions(const NodeOptions& options) {
  InputMonitorOptions monitor;
  monitor.timeout_s = options.input_timeout;
  monitor.max_interval_s = options.odometry_max_interval;
  return monitor;
}

}  // namespace

NodeOptions loadNodeOptions(const ros::NodeHandle& private_node) {
  const RosParameterSource source(private_node);
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  for (const std::string& note : condensedParameterNotes(parameterNotes(source.keys(), reader))) {
    ROS_WARN("Parameter %s/%s", private_node.getNamespace().c_str(), note.c_str());
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
      detector_(options.detector, makeDescriptorExtractor(options.detector.descriptor)),
      image_transport_(node),
      odometry_history_(2000, options.time_jump_back_s),
      inputs_(inputMonitorOptions(options), wallNow()),
      markers_(options.odom_frame, options.detector.acceptance.min_score,
               options.publish_rejected_markers),
      diagnostics_(node, private_node, ros::this_node::getName()) {
  loop_publisher_ = node_.advertise<LoopClosure>("loop_closures", 100);
  keyframe_publisher_ =
      node_.advertise<Keyframe>("keyframes", 1000);  // Bursts when the map's check passes.
  candidates_publisher_ = private_node_.advertise<LoopCandidateArray>("candidates", 10);
  // Each keyframe sends only the markers it changed (queued, so none is lost); a viewer that
  // connects later is sent everything once.
  markers_publisher_ = private_node_.advertise<visualization_msgs::MarkerArray>(
      "markers", 100, [this](const ros::SingleSubscriberPublisher& subscriber) {
        subscriber.publish(markers_.snapshot(ros::Time::now()));
      });
  image_transport::ImageTransport private_transport(private_node_);
  // Latched: the latest loop stays on view, also for a viewer that starts later.
  match_image_publisher_ = private_transport.advertise("match_image", 1, true);

  diagnostics_.setHardwareID("none");
  diagnostics_.add("loop closure", this, &LoopClosureNode::produceDiagnostics);
  diagnostics_timer_ = node_.createWallTimer(
      ros::WallDuration(kDiagnosticsPeriod), [this](const ros::WallTimerEvent&) {
        // The map's check ends on its own thread: said without a keyframe.
        runtime_->tryWithDetector([this](LoopDetector& detector) {
          reportMapDamage(detector.map().takeNewDamage());
          // Keyframes the map's check held are committed, and published, without waiting for
          // the next keyframe.
          publishAnnouncedKeyframes();
          noteMapSize(detector);
          return false;
        });
        diagnostics_.force_update();
      });

  // A keyframe is published once the map file holds it (after the warm-up and the map's check).
  detector_.map().announceKeyframes(true);
  // Until tf gives the mount, the configured one is not trusted for triangulation.
  if (options_.camera_mount_from_tf) detector_.setCameraMount(std::nullopt);
  if (options_.mountFromTfWhereKnown()) {
    ROS_INFO(
        "camera_mount is not set: looked up in tf (%s -> the images' frame_id) where tf has "
        "it, the default values until then",
        options_.base_frame.c_str());
  }
  if (!options_.database_path.empty()) {
    // Refusing to start leaves a map that cannot be opened as it is.
    const auto load_start = std::chrono::steady_clock::now();
    const std::string error = detector_.map().open(options_.database_path);
    const double load_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    if (!error.empty()) throw std::runtime_error(error);
    database_status_ = options_.database_path;
    session_ = detector_.session();
    for (const std::string& leftover : detector_.map().leftoversRemoved()) {
      ROS_INFO("Removed %s, left by a save that was interrupted", leftover.c_str());
    }
    for (const std::string& repair : detector_.map().repairs()) {
      ROS_WARN("Map %s: %s", options_.database_path.c_str(), repair.c_str());
    }
    noteMapSize(detector_);
    {
      const char* graph = detector_.map().graphBuilding()
                              ? "being built in the background, exact search meanwhile"
                          : detector_.database().graph() == nullptr ? "off"
                          : detector_.map().graphReused()           ? "read"
                                                                    : "built";
      ROS_INFO(
          "Map %s: %zu keyframes loaded in %.2f s (search graph %s, integrity %s); this run "
          "is session %u, every keyframe committed as it is stored",
          options_.database_path.c_str(), detector_.database().size(), load_s, graph,
          detector_.map().check().c_str(), detector_.session());
      if (detector_.map().keyframesNotSearched() > 0 || detector_.map().overMemoryBudget()) {
        ROS_WARN(
            "Map %s: its first %zu keyframes fill advanced/database/memory_budget_mb (%.0f MB; or "
            "its saved "
            "search graph covers them: delete %s-graph to build one within the budget) and are "
            "searched; %zu later ones stay in the map unsearched, and new keyframes are written "
            "to it unsearched (raise the budget to search them)",
            options_.database_path.c_str(), detector_.database().size(),
            options_.detector.database.memory_budget_mb, options_.database_path.c_str(),
            detector_.map().keyframesNotSearched());
      }
    }
  }
  RuntimeOptions runtime_options;
  runtime_options.queue_size = static_cast<size_t>(options_.worker_queue_size);
  runtime_options.time_jump_back = options_.time_jump_back;
  runtime_options.time_jump_back_s = options_.time_jump_back_s;
  runtime_options.time_jump_frames = static_cast<size_t>(options_.time_jump_frames);
  runtime_options.max_stamp_ahead_s = options_.max_stamp_ahead_s;
  RuntimeListener listener;
  listener.prepare = [this](const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                            InputError* error) {
    return prepareKeyframe(job, colour, prepared, error);
  };
  listener.rejected = [this](const InputError& error) { reportRejected(error); };
  listener.timeline_reset = [this] { onTimelineReset(); };
  listener.keyframe = [this](const KeyframeJob& job, const KeyframeResult& result,
                             const PreparedKeyframe& prepared) {
    onKeyframeDone(job, result, prepared);
  };
  listener.failed = [this](const KeyframeJob& job, const std::string& what) {
    ROS_ERROR_THROTTLE(kWarningPeriod,
                       "Keyframe %lu at %.3f dropped: its processing threw (%s); the detector goes "
                       "on with the next (%lu so far, diagnostics: keyframes failed)",
                       static_cast<unsigned long>(job.id), job.stamp, what.c_str(),
                       static_cast<unsigned long>(runtime_ ? runtime_->keyframesFailed() : 0));
  };
  runtime_ = std::make_unique<DetectorRuntime>(&detector_, runtime_options, std::move(listener));
  if (options_.fleet.share || !options_.fleet.peerList().empty()) {
    FleetLink::Hooks hooks;
    hooks.with_detector = [this](const std::function<void(LoopDetector&)>& action) {
      runtime_->withDetector([&action](LoopDetector& detector) {
        action(detector);
        return false;
      });
    };
    hooks.intrinsics = [this] {
      MutexLock lock(stats_mutex_);
      return camera_intrinsics_;
    };
    hooks.base_frame = options_.base_frame;
    hooks.camera_frame = [this] { return keyframes_camera_frame_; };
    hooks.express_relative_pose = [this](AcceptedLoop* loop) {
      return expressRelativePose(loop, keyframes_camera_frame_);
    };
    hooks.publish_loop = [this](const LoopClosure& loop) {
      loop_publisher_.publish(loop);
      ++loops_published_;
    };
    fleet_ = std::make_unique<FleetLink>(node_, private_node_, options_.fleet, detector_,
                                         std::move(hooks));
  }
  advertiseServices();
  subscribe();
  const std::string descriptor = detector_.extractor()->name();
  ROS_INFO("Loop closure (%s): descriptor %s, pose from %s, listening on %s%s%s (camera_info %s)",
           toString(detector_.mode()), descriptor.c_str(),
           nameOf(poseSourceNames(), options_.pose_source).c_str(), image_topic_.c_str(),
           odom_topic_.empty() ? "" : " and ", odom_topic_.c_str(),
           camera_info_subscriber_.getTopic().c_str());
  if (!options_.fallback_warning.empty()) ROS_WARN("%s", options_.fallback_warning.c_str());
  if (!options_.ignored_warning.empty()) ROS_WARN("%s", options_.ignored_warning.c_str());
  if (detector_.mode() == DetectorMode::kLocalization && detector_.database().empty()) {
    ROS_WARN(
        "mode is localization but the keyframe database is empty: nothing will be found "
        "and nothing is added");
  }
}

LoopClosureNode::~LoopClosureNode() {
  if (fleet_) fleet_->stop();
  if (service_spinner_) service_spinner_->stop();
  const size_t unprocessed = runtime_->queued();
  runtime_->stop();
  // Between ROS shutting down and this point the worker may have stored keyframes it could no
  // longer publish: the last line says so, so the map's count and the topic's can be reconciled.
  std::string shutdown_note;
  if (const uint64_t unpublished = keyframes_unpublished_at_shutdown_.load(); unpublished > 0) {
    shutdown_note +=
        "; " + std::to_string(unpublished) +
        " of them stored while ROS shut down, which may not have reached keyframes' subscribers";
  }
  if (unprocessed > 0) {
    shutdown_note += "; " + std::to_string(unprocessed) + " queued keyframes not processed";
  }
  runtime_->withDetector([&shutdown_note](LoopDetector& detector) {
    if (detector.map().path().empty()) return false;
    const ros::WallTime start = ros::WallTime::now();
    const std::string error = detector.map().saveGraph();
    const double seconds = (ros::WallTime::now() - start).toSec();
    if (!error.empty()) logAtStop(ros::console::levels::Warn, error);
    std::ostringstream line;
    // What is on disk, not what was in memory: a damaged map or a full disk kept some out.
    if (const size_t unwritten = detector.map().keyframesNotWritten(); unwritten > 0) {
      line << "Map " << detector.map().path() << ": " << detector.map().keyframesInFile()
           << " keyframes in the file; " << unwritten << " keyframes of this run are not in it ("
           << (detector.map().check() == "damaged" ? "the map is damaged and never written to"
                                                   : "writing failed")
           << "), they were in memory only";
    } else {
      line << "Map " << detector.map().path() << ": " << detector.map().keyframesInFile()
           << " keyframes, each committed when it was stored";
    }
    line << shutdown_note
         << (error.empty() ? "; search graph and rows saved in " : "; search files not saved, ")
         << std::fixed << std::setprecision(2) << seconds << " s";
    logAtStop(ros::console::levels::Info, line.str());
    return false;
  });
}

void LoopClosureNode::subscribe() {
  // Never lazy: a detector that stops listening loses keyframes for good.
  image_topic_ = node_.resolveName("image");
  // camera_info remapped (the launch file's camera_info argument): that topic; else the one
  // beside the image, as image_transport's camera subscribers take it.
  const std::string remapped_info = node_.resolveName("camera_info");
  const std::string info_topic = remapped_info != node_.resolveName("camera_info", false)
                                     ? remapped_info
                                     : image_transport::getCameraInfoTopic(image_topic_);
  camera_info_subscriber_ = node_.subscribe(info_topic, 1, &LoopClosureNode::onCameraInfo, this);
  if (options_.use_depth) {
    // Every queued keyframe (and the one in the worker) keeps its depth image however far behind
    // the worker is.
    depth_buffer_.setMaxWanted(static_cast<size_t>(options_.worker_queue_size) + 2);
    // As deep as the buffer: with callbacks late on a busy machine, a queue of 5 dropped the
    // depth of an image the image queue kept.
    depth_subscriber_ =
        image_transport_.subscribe("depth", kDepthQueue, &LoopClosureNode::onDepth, this);
  }
  if (options_.pose_source == PoseSource::kTf || options_.camera_mount_from_tf ||
      options_.mountFromTfWhereKnown()) {
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, node_);
  }
  if (options_.pose_source == PoseSource::kTf) {
    image_subscriber_ =
        image_transport_.subscribe("image", 5, &LoopClosureNode::onImageForTf, this);
    tf_timer_ = node_.createWallTimer(ros::WallDuration(kTfRetryPeriod),
                                      [this](const ros::WallTimerEvent&) { retryPendingTf(); });
    return;
  }
  odom_topic_ = node_.resolveName("odom");
  const uint32_t queue = static_cast<uint32_t>(options_.sync_queue_size);
  image_subscriber_ =
      image_transport_.subscribe("image", queue, &LoopClosureNode::onImageForOdometry, this);
  // Odometry usually comes faster than images: enough for the images' wait.
  odom_subscriber_ = node_.subscribe("odom", 200, &LoopClosureNode::onOdometry, this);
}

}  // namespace landmark_loop_closure
