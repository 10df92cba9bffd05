#include "landmark_loop_closure/backend/pose_graph_session.h"

#include <algorithm>
#include <cstdio>
#include <utility>

namespace landmark_loop_closure {
namespace {

std::string loopName(const GraphLoop& loop) {
  return "loop " + std::to_string(loop.constraint.query_id) + " -> " +
         std::to_string(loop.constraint.match_id);
}

}  // namespace

PoseGraphSession::PoseGraphSession(PoseGraphNodeOptions options, MountLookup mount)
    : options_(std::move(options)),
      mount_(std::move(mount)),
      graph_(std::make_unique<PoseGraph>(options_.graph)) {}

GraphStep PoseGraphSession::process(const std::vector<Input>& batch) {
  GraphStep step;
  bool new_loops = false;
  bool new_keyframes = false;
  for (const Input& input : batch) {
    if (const auto* keyframe = std::get_if<GraphKeyframe>(&input)) {
      new_keyframes |= addKeyframe(*keyframe, &step);
    } else {
      waiting_loops_.push_back(std::get<GraphLoop>(input));
    }
  }
  // A loop is published before its query keyframe: it waits for it (a few keyframes at most).
  std::vector<GraphLoop> still_waiting;
  for (const GraphLoop& loop : waiting_loops_) {
    const uint64_t query_id = loop.constraint.query_id;
    if (graph_->hasKeyframe(query_id) || graph_->keyframes() == 0 ||
        graph_->ids().back() > query_id + kLoopWaitKeyframes) {
      new_loops |= addLoop(loop, &step);
    } else {
      still_waiting.push_back(loop);
    }
  }
  // Loops waiting for keyframes that never come (ids from elsewhere) must not pile up.
  while (still_waiting.size() > kMaxWaitingLoops) {
    new_loops |= addLoop(still_waiting.front(), &step);
    still_waiting.erase(still_waiting.begin());
  }
  waiting_loops_.swap(still_waiting);
  if (new_loops) {
    const OptimisationReport report = graph_->optimise();
    if (report.ran) optimisation_ms_.push_back(report.milliseconds);
    for (const uint64_t index : report.switched_off) {
      const LoopVerdict& verdict = graph_->loopVerdicts()[index];
      const GraphLoop& loop = graph_loops_[index];
      step.notices.push_back({GraphNotice::Kind::kLoopSwitchedOff,
                              loopName(loop) + " switched off: " + verdict.detail});
      step.verdicts.push_back({loop, toString(verdict.decision), verdict.error_sd, verdict.detail});
    }
  }
  step.changed = new_loops || new_keyframes;
  // The whole corrected path after an optimisation, else every 10 keyframes (it grows); the
  // caller also publishes it when no input has come for a while (pathsBehind).
  step.publish_paths = step.changed && (new_loops || paths_stale_ || graph_->keyframes() % 10 == 0);
  return step;
}

bool PoseGraphSession::pathsPublished() {
  const bool new_graph = paths_stale_;
  paths_stale_ = false;
  keyframes_in_paths_ = graph_->keyframes();
  return new_graph;
}

bool PoseGraphSession::addKeyframe(const GraphKeyframe& keyframe, GraphStep* step) {
  // A keyframe the graph would refuse must not replace the graph (nor place the new one).
  std::string problem = PoseGraph::odometryPoseProblem(keyframe.id, keyframe.odometry);
  if (problem.empty() && map_id_ && (*map_id_ != keyframe.map_id || session_ != keyframe.session)) {
    startOver(keyframe, step);
  }
  if (problem.empty()) problem = graph_->addKeyframe(keyframe.id, keyframe.odometry);
  if (!problem.empty()) {
    step->notices.push_back({GraphNotice::Kind::kKeyframeDropped, "keyframe dropped: " + problem});
    return false;
  }
  map_id_ = keyframe.map_id;
  session_ = keyframe.session;
  odometry_frame_ = keyframe.odometry_frame;
  stamps_ns_.push_back(keyframe.stamp_ns);
  return true;
}

// The detector went on in another map (it was reset, loaded one, or restarted) or session (its
// odometry was re-initialised): a new graph. While time goes on in another map the odometry frame
// is the same, so the new graph starts from the old one's correction (map -> odom does not jump);
// a new session's odometry frame is another, so the new graph starts where the old one last saw
// the robot; after time went back (a bag played again) the odometry starts afresh, and so does
// the correction.
void PoseGraphSession::startOver(const GraphKeyframe& keyframe, GraphStep* step) {
  const bool time_went_back = !stamps_ns_.empty() && keyframe.stamp_ns < stamps_ns_.back();
  const bool new_map = *map_id_ != keyframe.map_id;
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  const char* start = "map -> odom from identity (time went back: a new timeline)";
  if (!time_went_back && new_map) {
    correction = graph_->mapFromOdometry();
    start = "map -> odom where the old graph left it";
  } else if (!time_went_back) {
    correction = graph_->optimisedPose(graph_->ids().back())->toIsometry() *
                 keyframe.odometry.toIsometry().inverse();
    start = "placed where the old graph last saw the robot";
  }
  char cause[160];
  if (new_map) {
    std::snprintf(cause, sizeof(cause),
                  "is of map %llu, not %llu (the detector was reset, loaded a map or restarted)",
                  static_cast<unsigned long long>(keyframe.map_id),
                  static_cast<unsigned long long>(*map_id_));
  } else {
    std::snprintf(cause, sizeof(cause),
                  "starts session %u after %u (the odometry was re-initialised: another odometry "
                  "frame)",
                  keyframe.session, session_);
  }
  char text[480];
  std::snprintf(text, sizeof(text),
                "keyframe %llu %s: a new graph starts with it, %s; the old graph's %zu keyframes "
                "and %zu loops are dropped",
                static_cast<unsigned long long>(keyframe.id), cause, start, graph_->keyframes(),
                graph_->loopVerdicts().size());
  // Throttled when the old graph had a single keyframe: two detectors on one topic would start a
  // graph at every keyframe.
  step->notices.push_back({GraphNotice::Kind::kNewGraph, text, graph_->keyframes() <= 1});
  for (const LoopVerdict& verdict : graph_->loopVerdicts()) {
    ++earlier_decisions_[toString(verdict.decision)];
  }
  ++graphs_dropped_;
  graph_ = std::make_unique<PoseGraph>(options_.graph, correction);
  map_id_.reset();
  stamps_ns_.clear();
  graph_loops_.clear();
  paths_stale_ = true;
}

bool PoseGraphSession::addLoop(const GraphLoop& loop, GraphStep* step) {
  const char* left_out = nullptr;
  if (!loop.has_relative_pose) {
    left_out = "no relative pose (verified by appearance, or the pose was ambiguous)";
  } else if (!loop.relative_pose_metric) {
    left_out = "scale-free relative pose (a metric graph takes metric loops only)";
  } else if (loop.query_session != loop.match_session) {
    left_out =
        "it joins another session (an earlier run, or the odometry before it was "
        "re-initialised), whose odometry frame is not this one";
  } else if (map_id_ && loop.map_id != *map_id_) {
    left_out = "another map than the keyframes'";
  } else if (map_id_ && loop.query_session != session_) {
    left_out = "another session than the keyframes'";
  }
  std::optional<Eigen::Isometry3d> mount;
  std::string mount_problem;
  if (!left_out && loop.relative_pose_frame != options_.base_frame) {
    if (!options_.detector_base_frame.empty() &&
        loop.relative_pose_frame == options_.detector_base_frame) {
      // The detector's body frame under another name than ours: the mount must not be applied.
      mount_problem = "its frame is the detector's base_frame '" + loop.relative_pose_frame +
                      "', not this graph's base_frame '" + options_.base_frame +
                      "': set the two alike";
      left_out = "its frame is the detector's base_frame, another than the graph's";
    } else if (mount_) {
      mount = mount_(loop.relative_pose_frame, &mount_problem);
      if (!mount) left_out = "its frame is not on tf (camera_mount/from_tf)";
    } else {
      left_out = "its frame is not the base frame, and no camera mount is known";
    }
  }
  if (left_out) {
    ++left_out_[left_out];
    step->verdicts.push_back(
        {loop, "left_out", 0.0, mount_problem.empty() ? left_out : mount_problem});
    return false;
  }
  LoopConstraint constraint = loop.constraint;
  if (mount) constraint = loopInBaseFrame(constraint, *mount);
  graph_loops_.push_back(loop);
  const LoopVerdict verdict = graph_->addLoop(constraint);
  step->verdicts.push_back({loop, toString(verdict.decision), verdict.error_sd, verdict.detail});
  for (const size_t index : verdict.confirmed) {
    const LoopVerdict& confirmed = graph_->loopVerdicts()[index];
    step->verdicts.push_back(
        {graph_loops_[index], toString(confirmed.decision), confirmed.error_sd, confirmed.detail});
  }
  // Most loops are accepted and need no line: the name is built only for one.
  const auto said = [&loop] { return loopName(loop) + " "; };
  if (verdict.decision == LoopDecision::kAwaitingConfirmation) {
    step->notices.push_back({GraphNotice::Kind::kLoopAwaiting, said() + verdict.detail});
  } else if (verdict.decision == LoopDecision::kUnknownKeyframe ||
             verdict.decision == LoopDecision::kBadPose ||
             verdict.decision == LoopDecision::kBadCovariance) {
    step->notices.push_back(
        {GraphNotice::Kind::kLoopBadInput,
         said() + "dropped as bad input (" + toString(verdict.decision) + "): " + verdict.detail});
  } else if (verdict.decision != LoopDecision::kAccepted) {
    step->notices.push_back(
        {GraphNotice::Kind::kLoopRefused,
         said() + "refused (" + toString(verdict.decision) + "): " + verdict.detail});
  }
  return verdict.decision == LoopDecision::kAccepted || !verdict.confirmed.empty();
}

std::string PoseGraphSession::summary() const {
  std::map<std::string, size_t> decisions = earlier_decisions_;
  for (const LoopVerdict& verdict : graph_->loopVerdicts()) ++decisions[toString(verdict.decision)];
  std::string loops;
  for (const auto& [decision, count] : decisions) {
    loops += " " + decision + " " + std::to_string(count);
  }
  for (const auto& [reason, count] : left_out_) {
    loops += "; left out " + std::to_string(count) + ": " + reason;
  }
  std::vector<double> times = optimisation_ms_;
  std::sort(times.begin(), times.end());
  const double median = times.empty() ? 0.0 : times[times.size() / 2];
  // A rate of 0 from a graph told not to estimate one would read as a measurement.
  char drift[64] = "not estimated";
  if (options_.graph.heading_drift_prior_sd_per_m > 0.0) {
    std::snprintf(drift, sizeof(drift), "estimated %.4f rad/m", graph_->headingDriftPerMetre());
  }
  char earlier[96] = "";
  if (graphs_dropped_ > 0) {
    std::snprintf(earlier, sizeof(earlier),
                  " (%zu earlier graph(s) of other maps or sessions dropped)", graphs_dropped_);
  }
  char line[320];
  std::snprintf(line, sizeof(line),
                "Pose graph: %zu keyframes%s; %zu optimisations, median %.1f ms; odometry "
                "heading drift %s; loops:",
                graph_->keyframes(), earlier, times.size(), median, drift);
  return line + loops;
}

}  // namespace landmark_loop_closure
