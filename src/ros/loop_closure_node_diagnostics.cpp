// The node's diagnostics: input health, counters, timings.
#include <sstream>
#include <string>

#include "loop_closure_node.h"

namespace landmark_loop_closure {

std::string LoopClosureNode::cameraInfoProblem() {
  MutexLock lock(stats_mutex_);
  return camera_info_problem_;
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

void LoopClosureNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const double now = wallNow();
  const uint64_t drops = runtime_->keyframesDropped();
  if (drops > drops_seen_) {
    drops_seen_ = drops;
    last_drop_wall_ = now;
  }
  const bool use_odom = options_.pose_source == PoseSource::kOdom;
  std::ostringstream waiting;
  if (inputs_.imageSilent(now)) waiting << image_topic_;
  if (use_odom && inputs_.poseSilent(now)) {
    waiting << (waiting.tellp() > 0 ? " and " : "") << odom_topic_;
  }
  if (!use_odom && tf_timeouts_ > 0 && inputs_.poseSilent(now)) {
    waiting << (waiting.tellp() > 0 ? " and " : "") << "tf " << options_.odom_frame << " -> "
            << options_.base_frame;
  }
  const std::string unpaired = use_odom ? inputs_.unpaired(now) : "";
  // The worst level, with every problem named (mergeSummary joins the texts of that level).
  status.summary(diagnostic_msgs::DiagnosticStatus::OK, "Running");
  if (now - last_time_jump_wall_ < kTimeJumpErrorS) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::ERROR,
                         "Time jumped back (%d frames in a row before the last keyframe) %.0f s "
                         "ago: a new timeline started",
                         options_.time_jump_frames, now - last_time_jump_wall_);
  }
  if (waiting.tellp() > 0) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "No input for %.0f s on %s",
                         options_.input_timeout, waiting.str().c_str());
  } else if (!unpaired.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, unpaired);
    ROS_WARN_THROTTLE(kWarningPeriod, "%s", unpaired.c_str());
  }
  if (const std::string problem = cameraInfoProblem(); !problem.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN,
                        "geometric check off: camera_info invalid (" + problem + ")");
  }
  if (options_.use_depth && depth_silence_reported_) {
    status.mergeSummary(
        diagnostic_msgs::DiagnosticStatus::WARN,
        "no depth image on " + depth_subscriber_.getTopic() + ": keyframes go on without depth");
  }
  if (now - last_drop_wall_ < kDropWarningS) {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "the worker dropped keyframes in the last %.0f s", kDropWarningS);
  }

  if (fleet_) fleet_->diagnose(status);
  const InputMonitor::Rates rates = inputs_.takeRates(now);
  MutexLock lock(stats_mutex_);
  if (!map_damage_.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR,
                        "no loops searched: " + map_damage_);
  }
  if (!map_write_problem_.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR,
                        mapWriteSummary(map_write_problem_, keyframes_not_written_));
  }
  status.add("image topic", image_topic_);
  if (use_odom) status.add("odometry topic", odom_topic_);
  status.addf("image rate (Hz)", "%.1f", rates.image_hz);
  status.addf("pose rate (Hz)", "%.1f", rates.pose_hz);
  status.add("camera_info", !camera_info_seen_             ? "none received"
                            : camera_info_problem_.empty() ? "usable"
                                                           : "invalid: " + camera_info_problem_);
  status.add("frames admitted", frames_admitted_.load());
  status.add("keyframes", map_keyframes_.load());
  status.add("database bytes", database_bytes_);
  status.add("keyframes past the memory budget", keyframes_over_budget_.load());
  status.add("keyframes not stored (map file refused them)", keyframes_not_written_);
  status.add("map", database_status_);
  if (!map_check_.empty()) status.add("map check", map_check_);
  status.add("session", session_.load());
  status.add("loops published", loops_published_.load());
  status.add("keyframes dropped (worker busy)", runtime_->keyframesDropped());
  status.add("keyframes dropped at a map switch", runtime_->keyframesDroppedAtMapSwitch());
  status.add("keyframes failed (processing threw)", runtime_->keyframesFailed());
  status.add("time jumps (new timelines)", runtime_->timeJumps());
  status.add("queued keyframes", runtime_->queued());
  status.add("odometry jumps", odometry_jumps_.load());
  if (!use_odom) status.add("tf timeouts", tf_timeouts_.load());
  if (options_.use_depth) {
    status.add("depth stream",
               depth_silence_reported_ ? "silent: advertised, nothing published" : "ok");
    status.add("keyframes with depth", keyframes_with_depth_.load());
    status.add("keyframes without depth", keyframes_without_depth_.load());
  }
  status.addf("last keyframe processing (ms)", "%.1f", runtime_->lastProcessingMs());
  status.addf("max keyframe processing (ms)", "%.1f", runtime_->maxProcessingMs());
  for (const auto& [code, count] : inputs_.rejections()) {
    status.add(std::string("rejected: ") + toString(code), count);
  }
}

}  // namespace landmark_loop_closure
