// The node's wiring: options, the detector and its runtime, and the parts around them (inputs,
// outputs, map services, diagnostics, the fleet link); what it says at start and at stop.
#include "loop_closure_node.h"

#include <chrono>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "frame_source.h"
#include "landmark_loop_closure/common/model_directory.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "messages/ros_conversions.h"
#include "ros_parameter_source.h"

namespace landmark_loop_closure {

namespace {

constexpr double kDiagnosticsPeriod = 1.0;

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

}  // namespace

NodeOptions loadNodeOptions(const ros::NodeHandle& private_node) {
  const RosParameterSource source(private_node);
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  // The first line: which network describes keyframes, and why when it is not the default one.
  const DescriptorOptions& descriptor = options.detector.descriptor;
  const std::string models = " (package models from " + modelDirectory() + ")";
  if (!options.fallback_warning.empty()) {
    ROS_WARN("Descriptor: %s%s", options.fallback_warning.c_str(), models.c_str());
  } else if (descriptor.type == "backbone") {
    ROS_INFO("Descriptor backbone: the pretrained network %s%s",
             (descriptor.backbone.model.empty() ? defaultBackbonePath() : descriptor.backbone.model)
                 .c_str(),
             models.c_str());
  } else {
    ROS_INFO("Descriptor %s (advanced/descriptor/type)%s", descriptor.type.c_str(), models.c_str());
  }
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
      diagnostics_(node, private_node, options_, &counters_),
      inputs_(node, options_, &counters_) {
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
  if (!options_.database_path.empty()) openMap();
  RuntimeOptions runtime_options;
  runtime_options.queue_size = static_cast<size_t>(options_.worker_queue_size);
  runtime_options.time_jump_back = options_.time_jump_back;
  runtime_options.time_jump_back_s = options_.time_jump_back_s;
  runtime_options.time_jump_frames = static_cast<size_t>(options_.time_jump_frames);
  runtime_options.max_stamp_ahead_s = options_.max_stamp_ahead_s;
  runtime_ = std::make_unique<DetectorRuntime>(&detector_, runtime_options, runtimeListener());
  outputs_ = std::make_unique<NodeOutputs>(node_, private_node_, options_, &counters_,
                                           runtime_->detectorMutex());
  if (options_.fleet.share || !options_.fleet.peerList().empty()) startFleet();
  outputs_->setFleet(fleet_.get());
  services_ =
      std::make_unique<MapServices>(private_node_, runtime_.get(), outputs_.get(), &diagnostics_);
  diagnostics_.start(&inputs_, runtime_.get(), fleet_.get());
  diagnostics_timer_ =
      node_.createWallTimer(ros::WallDuration(kDiagnosticsPeriod),
                            [this](const ros::WallTimerEvent&) { onDiagnosticsTimer(); });
  inputs_.start(runtime_.get());
  const std::string descriptor = detector_.extractor()->name();
  ROS_INFO("Loop closure (%s): descriptor %s, pose from %s, listening on %s%s%s (camera_info %s)",
           toString(detector_.mode()), descriptor.c_str(),
           nameOf(poseSourceNames(), options_.pose_source).c_str(), inputs_.imageTopic().c_str(),
           inputs_.odometryTopic().empty() ? "" : " and ", inputs_.odometryTopic().c_str(),
           inputs_.cameraInfoTopic().c_str());
  if (!options_.ignored_warning.empty()) ROS_WARN("%s", options_.ignored_warning.c_str());
  if (detector_.mode() == DetectorMode::kLocalization && detector_.database().empty()) {
    ROS_WARN(
        "mode is localization but the keyframe database is empty: nothing will be found "
        "and nothing is added");
  }
}

void LoopClosureNode::openMap() {
  // Refusing to start leaves a map that cannot be opened as it is.
  const auto load_start = std::chrono::steady_clock::now();
  const std::string error = detector_.map().open(options_.database_path);
  const double load_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
  if (!error.empty()) throw std::runtime_error(error);
  diagnostics_.setMapStatus(options_.database_path);
  for (const std::string& leftover : detector_.map().leftoversRemoved()) {
    ROS_INFO("Removed %s, left by a save that was interrupted", leftover.c_str());
  }
  for (const std::string& repair : detector_.map().repairs()) {
    ROS_WARN("Map %s: %s", options_.database_path.c_str(), repair.c_str());
  }
  diagnostics_.noteMap(detector_);
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

RuntimeListener LoopClosureNode::runtimeListener() {
  RuntimeListener listener;
  listener.prepare = [this](const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                            InputError* error) {
    return inputs_.prepare(job, colour, prepared, error);
  };
  listener.rejected = [this](const InputError& error) { inputs_.reportRejected(error); };
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
  return listener;
}

void LoopClosureNode::startFleet() {
  FleetLink::Hooks hooks;
  hooks.with_detector = [this](const std::function<void(LoopDetector&)>& action) {
    runtime_->withDetector([&action](LoopDetector& detector) {
      action(detector);
      return false;
    });
  };
  hooks.intrinsics = [this] { return inputs_.cameraInfo().latest(); };
  hooks.base_frame = options_.base_frame;
  // Both called within hooks.with_detector.
  hooks.camera_frame = [this] {
    outputs_->assertDetectorHeld();
    return outputs_->cameraFrame();
  };
  hooks.express_relative_pose = [this](AcceptedLoop* loop) {
    outputs_->assertDetectorHeld();
    return outputs_->expressRelativePose(detector_, loop, outputs_->cameraFrame());
  };
  hooks.publish_loop = [this](const LoopClosure& loop) { outputs_->publishLoop(loop); };
  fleet_ = std::make_unique<FleetLink>(node_, private_node_, options_.fleet, detector_,
                                       std::move(hooks));
}

void LoopClosureNode::onDiagnosticsTimer() {
  runtime_->tryWithDetector([this](LoopDetector& detector) {
    outputs_->assertDetectorHeld();  // tryWithDetector runs this with it held.
    reportMapDamage(detector.map().takeNewDamage());
    outputs_->publishAnnounced(detector);
    diagnostics_.noteMap(detector);
    return false;
  });
  diagnostics_.update();
}

void LoopClosureNode::reportMapDamage(const std::string& damage) {
  if (damage.empty()) return;
  ROS_ERROR(
      "%s: no loops are searched from now on and nothing more is written to the map (new "
      "keyframes are kept in memory only); ~reset keeps it aside and starts a new map, "
      "~load_database switches to a sound one",
      damage.c_str());
}

void LoopClosureNode::onTimelineReset() {
  outputs_->assertDetectorHeld();  // The runtime's listener runs with it held.
  diagnostics_.noteMap(detector_);
  outputs_->forgetMap();
}

void LoopClosureNode::onKeyframeDone(const KeyframeJob& job, const KeyframeResult& result,
                                     const PreparedKeyframe& prepared) {
  outputs_->assertDetectorHeld();  // The runtime's listener runs with it held.
  const bool mapping = detector_.mode() == DetectorMode::kMapping;
  // Not stored and no store error: past the budget without a map file.
  const bool over_budget =
      result.written_not_searched || (!result.stored && result.store_error.empty());
  if (mapping && over_budget) {
    ++counters_.keyframes_over_budget;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Database memory budget of %.0f MB reached (%zu keyframes searched): new "
                      "keyframes are searched for loops and %s",
                      options_.detector.database.memory_budget_mb, detector_.database().size(),
                      result.written_not_searched
                          ? "written to the map, not searched (raise the budget to search them)"
                          : "no longer stored (without a map file, database_path, all is in RAM)");
  }
  reportMapDamage(result.map_damage);
  // The keyframes carry the session (a camera gap keeps it, an odometry restart starts one).
  counters_.session = detector_.session();
  outputs_->publishKeyframe(detector_, NodeKeyframe::of(job), result, prepared.grey);
  if (!result.store_error.empty()) {
    ROS_ERROR_THROTTLE(kWarningPeriod, "Keyframe %lu %s: %s (%zu keyframes not stored so far)",
                       static_cast<unsigned long>(job.id),
                       result.stored         ? "is held back, but its id could not be reserved"
                       : result.loop_dropped ? "is neither stored nor published, nor its loop"
                                             : "is neither stored nor published",
                       result.store_error.c_str(), detector_.map().keyframesNotWritten());
  }
  diagnostics_.noteMap(detector_);
}

LoopClosureNode::~LoopClosureNode() {
  if (fleet_) fleet_->stop();
  services_->stop();
  const size_t unprocessed = runtime_->queued();
  runtime_->stop();
  // Between ROS shutting down and this point the worker may have stored keyframes it could no
  // longer publish: the last line says so, so the map's count and the topic's can be reconciled.
  std::string shutdown_note;
  if (const uint64_t unpublished = counters_.keyframes_unpublished_at_shutdown.load();
      unpublished > 0) {
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

}  // namespace landmark_loop_closure
