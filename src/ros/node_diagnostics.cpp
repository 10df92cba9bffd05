#include "node_diagnostics.h"

#include <sstream>
#include <string>

#include "fleet_link.h"

namespace landmark_loop_closure {

NodeDiagnostics::NodeDiagnostics(ros::NodeHandle node, ros::NodeHandle private_node,
                                 const NodeOptions& options, NodeCounters* counters)
    : options_(options),
      counters_(*counters),
      updater_(node, private_node, ros::this_node::getName()) {
  updater_.setHardwareID("none");
}

void NodeDiagnostics::start(NodeInputs* inputs, const DetectorRuntime* runtime, FleetLink* fleet) {
  inputs_ = inputs;
  runtime_ = runtime;
  fleet_ = fleet;
  updater_.add("loop closure", this, &NodeDiagnostics::produce);
}

void NodeDiagnostics::noteMap(const LoopDetector& detector) {
  counters_.map_keyframes = detector.database().size();
  counters_.session = detector.session();
  MutexLock lock(mutex_);
  database_bytes_ = detector.database().bytes();
  map_check_ = detector.map().check();
  map_damage_ = detector.map().damage();
  map_write_problem_ = detector.map().writeProblem();
  keyframes_not_written_ = detector.map().keyframesNotWritten();
}

void NodeDiagnostics::setMapStatus(const std::string& status) {
  MutexLock lock(mutex_);
  map_status_ = status;
}

namespace {

constexpr double kDropWarningS = 30.0;    // A drop keeps diagnostics at WARN this long.
constexpr double kTimeJumpErrorS = 30.0;  // A time jump keeps diagnostics at ERROR this long.

}  // namespace

std::string mapWriteSummary(const std::string& problem, size_t keyframes_not_stored) {
  const bool full = problem.find("disk is full") != std::string::npos ||
                    problem.find("No space left") != std::string::npos;
  return std::string(full ? "map file full: " : "map file not written: ") +
         std::to_string(keyframes_not_stored) + " keyframes not stored (" + problem + ")";
}

void NodeDiagnostics::produce(diagnostic_updater::DiagnosticStatusWrapper& status) {
  RoleScope reading(read_only_handler);
  const double now = ros::WallTime::now().toSec();
  const uint64_t drops = runtime_->keyframesDropped();
  if (drops > drops_seen_) {
    drops_seen_ = drops;
    last_drop_wall_ = now;
  }
  const bool use_odom = options_.pose_source == PoseSource::kOdom;
  std::ostringstream waiting;
  if (inputs_->monitor().imageSilent(now)) waiting << inputs_->imageTopic();
  if (use_odom && inputs_->monitor().poseSilent(now)) {
    waiting << (waiting.tellp() > 0 ? " and " : "") << inputs_->odometryTopic();
  }
  if (!use_odom && counters_.tf_timeouts > 0 && inputs_->monitor().poseSilent(now)) {
    waiting << (waiting.tellp() > 0 ? " and " : "") << "tf " << options_.odom_frame << " -> "
            << options_.base_frame;
  }
  const std::string unpaired = use_odom ? inputs_->monitor().unpaired(now) : "";
  // The worst level, with every problem named (mergeSummary joins the texts of that level).
  status.summary(diagnostic_msgs::DiagnosticStatus::OK, "Running");
  if (now - counters_.last_time_jump_wall < kTimeJumpErrorS) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::ERROR,
                         "Time jumped back (%d frames in a row before the last keyframe) %.0f s "
                         "ago: a new timeline started",
                         options_.time_jump_frames, now - counters_.last_time_jump_wall);
  }
  if (waiting.tellp() > 0) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "No input for %.0f s on %s",
                         options_.input_timeout, waiting.str().c_str());
  } else if (!unpaired.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, unpaired);
    ROS_WARN_THROTTLE(kWarningPeriod, "%s", unpaired.c_str());
  }
  if (const std::string problem = inputs_->cameraInfo().problem(); !problem.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN,
                        "geometric check off: camera_info invalid (" + problem + ")");
  }
  if (options_.use_depth && inputs_->preparation().depthSilent()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN,
                        "no depth image on " + inputs_->preparation().depthTopic() +
                            ": keyframes go on without depth");
  }
  if (now - last_drop_wall_ < kDropWarningS) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "the worker dropped keyframes in the last %.0f s", kDropWarningS);
  }

  if (fleet_) fleet_->diagnose(status);
  const InputMonitor::Rates rates = inputs_->monitor().takeRates(now);
  const bool camera_info_seen = inputs_->cameraInfo().seen();
  const std::string camera_info_problem = inputs_->cameraInfo().problem();
  MutexLock lock(mutex_);
  if (!map_damage_.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR,
                        "no loops searched: " + map_damage_);
  }
  if (!map_write_problem_.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR,
                        mapWriteSummary(map_write_problem_, keyframes_not_written_));
  }
  status.add("image topic", inputs_->imageTopic());
  if (use_odom) status.add("odometry topic", inputs_->odometryTopic());
  status.addf("image rate (Hz)", "%.1f", rates.image_hz);
  status.addf("pose rate (Hz)", "%.1f", rates.pose_hz);
  status.add("camera_info", !camera_info_seen             ? "none received"
                            : camera_info_problem.empty() ? "usable"
                                                          : "invalid: " + camera_info_problem);
  status.add("frames admitted", counters_.frames_admitted.load());
  status.add("keyframes", counters_.map_keyframes.load());
  status.add("database bytes", database_bytes_);
  status.add("keyframes past the memory budget", counters_.keyframes_over_budget.load());
  status.add("keyframes not stored (map file refused them)", keyframes_not_written_);
  status.add("map", map_status_);
  if (!map_check_.empty()) status.add("map check", map_check_);
  status.add("session", counters_.session.load());
  status.add("loops published", counters_.loops_published.load());
  status.add("keyframes dropped (worker busy)", runtime_->keyframesDropped());
  status.add("keyframes dropped at a map switch", runtime_->keyframesDroppedAtMapSwitch());
  status.add("keyframes failed (processing threw)", runtime_->keyframesFailed());
  status.add("time jumps (new timelines)", runtime_->timeJumps());
  status.add("queued keyframes", runtime_->queued());
  status.add("odometry jumps", counters_.odometry_jumps.load());
  if (!use_odom) status.add("tf timeouts", counters_.tf_timeouts.load());
  if (options_.use_depth) {
    status.add("depth stream", inputs_->preparation().depthSilent()
                                   ? "silent: advertised, nothing published"
                                   : "ok");
    status.add("keyframes with depth", counters_.keyframes_with_depth.load());
    status.add("keyframes without depth", counters_.keyframes_without_depth.load());
  }
  status.addf("last keyframe processing (ms)", "%.1f", runtime_->lastProcessingMs());
  status.addf("max keyframe processing (ms)", "%.1f", runtime_->maxProcessingMs());
  for (const auto& [code, count] : inputs_->monitor().rejections()) {
    status.add(std::string("rejected: ") + toString(code), count);
  }
}

}  // namespace landmark_loop_closure
