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
      graph_(std::make_unique<PoseGraph>(options_.graph)),
      fleet_(!options_.robotList().empty()) {}

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
    const auto last_of_map = last_id_of_map_.find(loop.map_id);
    if (graphId(loop.map_id, query_id) || graph_->keyframes() == 0 ||
        (last_of_map != last_id_of_map_.end() &&
         last_of_map->second > query_id + kLoopWaitKeyframes)) {
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

std::optional<uint64_t> PoseGraphSession::graphId(uint64_t map_id, uint64_t id) const {
  const auto found = graph_ids_.find({map_id, id});
  if (found == graph_ids_.end()) return std::nullopt;
  return found->second;
}

std::optional<Pose> PoseGraphSession::optimisedPose(uint64_t map_id, uint64_t id) const {
  const std::optional<uint64_t> graph_id = graphId(map_id, id);
  if (!graph_id) return std::nullopt;
  return graph_->optimisedPose(*graph_id);
}

std::map<std::string, Eigen::Isometry3d> PoseGraphSession::corrections() const {
  std::map<std::string, Eigen::Isometry3d> corrections;
  for (const auto& [frame, graph_id] : newest_in_frame_) {
    corrections[frame] = graph_->optimisedPose(graph_id)->toIsometry() *
                         graph_->odometryPose(graph_id)->toIsometry().inverse();
  }
  return corrections;
}

std::optional<size_t> PoseGraphSession::currentChain() const {
  if (graph_->keyframes() == 0) return std::nullopt;
  return graph_->chainOf(graph_->ids().back());
}

bool PoseGraphSession::addKeyframe(const GraphKeyframe& keyframe, GraphStep* step) {
  // A keyframe the graph would refuse must not replace the graph (nor start a chain).
  std::string problem = PoseGraph::odometryPoseProblem(keyframe.id, keyframe.odometry);
  // Time going back is a new timeline (a bag played again), unless the keyframe continues a map
  // the graph holds in a new session: a detector that loaded its map, replaying a bag on it.
  const bool continues_a_map = last_id_of_map_.count(keyframe.map_id) > 0 &&
                               chain_of_run_.count({keyframe.map_id, keyframe.session}) == 0;
  // Several robots' keyframes interleave: time goes back only within one of their maps.
  const auto last_stamp_of_map = last_stamp_of_map_.find(keyframe.map_id);
  const bool time_went_back = fleet_ ? last_stamp_of_map != last_stamp_of_map_.end() &&
                                           keyframe.stamp_ns < last_stamp_of_map->second
                                     : !stamps_ns_.empty() && keyframe.stamp_ns < stamps_ns_.back();
  if (problem.empty() && time_went_back && !continues_a_map) startOver(keyframe, step);
  const auto last_of_map = last_id_of_map_.find(keyframe.map_id);
  if (problem.empty() && last_of_map != last_id_of_map_.end() &&
      keyframe.id <= last_of_map->second) {
    problem = "keyframe id " + std::to_string(keyframe.id) + " of map " +
              std::to_string(keyframe.map_id) + " is not after the last one (" +
              std::to_string(last_of_map->second) + ")";
  }
  const Run run{keyframe.map_id, keyframe.session};
  const uint64_t graph_id = keys_.size();
  const auto chain = chain_of_run_.find(run);
  const char* placed = "";
  if (problem.empty()) {
    if (chain != chain_of_run_.end()) {
      problem = graph_->addToChain(chain->second, graph_id, keyframe.odometry);
    } else {
      problem =
          graph_->startChain(graph_id, keyframe.odometry, newChainPlacement(keyframe, &placed));
    }
  }
  if (!problem.empty()) {
    step->notices.push_back({GraphNotice::Kind::kKeyframeDropped, "keyframe dropped: " + problem});
    return false;
  }
  if (chain == chain_of_run_.end()) {
    chain_of_run_[run] = graph_->chains() - 1;
    if (graph_->chains() > 1) {
      char text[400];
      std::snprintf(text, sizeof(text),
                    "keyframe %llu starts chain %zu (map %llu, session %u: another odometry "
                    "frame), %s; it floats until loops join it to the others",
                    static_cast<unsigned long long>(keyframe.id), graph_->chains() - 1,
                    static_cast<unsigned long long>(keyframe.map_id), keyframe.session, placed);
      step->notices.push_back({GraphNotice::Kind::kNewChain, text});
      paths_stale_ = true;
    }
  }
  graph_ids_[{keyframe.map_id, keyframe.id}] = graph_id;
  keys_.emplace_back(keyframe.map_id, keyframe.id);
  last_id_of_map_[keyframe.map_id] = keyframe.id;
  current_run_ = run;
  odometry_frame_ = keyframe.odometry_frame;
  newest_in_frame_[keyframe.odometry_frame] = graph_id;
  stamps_ns_.push_back(keyframe.stamp_ns);
  last_stamp_of_map_[keyframe.map_id] = keyframe.stamp_ns;
  kept_.emplace_back(keyframe);
  ++kept_revision_;
  return true;
}

// While time goes on in another map the odometry frame may be the same (the detector was reset
// or loaded a map), so the new chain starts from the current correction (map -> odom does not
// jump); a new session's odometry frame is another, so the chain starts where the graph last saw
// the robot.
Eigen::Isometry3d PoseGraphSession::newChainPlacement(const GraphKeyframe& keyframe,
                                                      const char** how) const {
  if (graph_->keyframes() == 0) {
    *how = "at its odometry pose";
    return Eigen::Isometry3d::Identity();
  }
  if (current_run_ && current_run_->first != keyframe.map_id) {
    *how = "map -> odom where the graph left it";
    return graph_->mapFromOdometry();
  }
  *how = "placed where the graph last saw the robot";
  return graph_->optimisedPose(graph_->ids().back())->toIsometry() *
         keyframe.odometry.toIsometry().inverse();
}

// Time went back (a bag played again, the detector on a map of its own): another timeline, whose
// odometry starts afresh; the graph of the one before is dropped and the correction starts from
// identity.
void PoseGraphSession::startOver(const GraphKeyframe& keyframe, GraphStep* step) {
  char text[400];
  std::snprintf(text, sizeof(text),
                "keyframe %llu (map %llu) is stamped before the last one: time went back (a bag "
                "played again?), a new graph starts with it, map -> odom from identity; the old "
                "graph's %zu keyframes, %zu chains and %zu loops are dropped",
                static_cast<unsigned long long>(keyframe.id),
                static_cast<unsigned long long>(keyframe.map_id), graph_->keyframes(),
                graph_->chains(), graph_->loopVerdicts().size());
  // Throttled when the old graph had a single keyframe: two detectors on one topic with their
  // own clocks would start a graph at every keyframe.
  step->notices.push_back({GraphNotice::Kind::kNewGraph, text, graph_->keyframes() <= 1});
  for (const LoopVerdict& verdict : graph_->loopVerdicts()) {
    ++earlier_decisions_[toString(verdict.decision)];
  }
  ++graphs_dropped_;
  graph_ = std::make_unique<PoseGraph>(options_.graph);
  chain_of_run_.clear();
  graph_ids_.clear();
  keys_.clear();
  last_id_of_map_.clear();
  current_run_.reset();
  newest_in_frame_.clear();
  stamps_ns_.clear();
  last_stamp_of_map_.clear();
  graph_loops_.clear();
  kept_.clear();
  ++kept_revision_;
  paths_stale_ = true;
}

GraphStep PoseGraphSession::restore(const std::vector<Input>& inputs) {
  GraphStep restored;
  std::vector<Input> batch;
  const auto replay = [&] {
    if (batch.empty()) return;
    GraphStep step = process(batch);
    restored.changed |= step.changed;
    for (GraphNotice& notice : step.notices) restored.notices.push_back(std::move(notice));
    batch.clear();
  };
  for (const Input& input : inputs) {
    if (std::holds_alternative<GraphKeyframe>(input)) replay();
    batch.push_back(input);
  }
  replay();
  restored.publish_paths = restored.changed;
  return restored;
}

bool PoseGraphSession::addLoop(const GraphLoop& loop, GraphStep* step) {
  const char* left_out = nullptr;
  if (!loop.has_relative_pose) {
    left_out = "no relative pose (verified by appearance, or the pose was ambiguous)";
  } else if (!loop.relative_pose_metric) {
    left_out = "scale-free relative pose (a metric graph takes metric loops only)";
  }
  const std::optional<uint64_t> query = graphId(loop.map_id, loop.constraint.query_id);
  const std::optional<uint64_t> match = graphId(loop.matchMap(), loop.constraint.match_id);
  if (!left_out && query && !match && loop.matchMap() == loop.map_id &&
      loop.match_session != loop.query_session) {
    // A map loaded from a file: its keyframes were published by an earlier run, not to this
    // graph.
    left_out = "its match is a keyframe of an earlier run this graph never received";
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
    } else if (loop.matchMap() != loop.map_id && !loop.match_camera_mount) {
      // M_query T M_match^-1 needs the other robot's mount: this robot's would bias the loop by
      // the difference between the two.
      left_out = "a camera-frame pose between robots without the other robot's camera mount";
    } else if (loop.match_camera_mount && !isRotation(loop.match_camera_mount->linear(),
                                                      5e-3)) {  // As the graph checks poses.
      left_out = "the other robot's camera mount is not a rotation";
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
  if (mount) {
    // Within one map the query's mount is at both ends; between robots each end has its own.
    const Eigen::Isometry3d match_mount =
        loop.matchMap() != loop.map_id ? *loop.match_camera_mount : *mount;
    constraint = loopInBaseFrames(constraint, *mount, match_mount);
  }
  if (!query || !match) {
    const std::string detail =
        "keyframe " + std::to_string(query ? loop.constraint.match_id : loop.constraint.query_id) +
        " of map " + std::to_string(query ? loop.matchMap() : loop.map_id) + " is not in the graph";
    const std::string decision = toString(LoopDecision::kUnknownKeyframe);
    step->verdicts.push_back({loop, decision, 0.0, detail});
    step->notices.push_back(
        {GraphNotice::Kind::kLoopBadInput,
         loopName(loop) + " dropped as bad input (" + decision + "): " + detail});
    return false;
  }
  constraint.query_id = *query;
  constraint.match_id = *match;
  graph_loops_.push_back(loop);
  GraphLoop in_base_frame = loop;
  in_base_frame.relative_pose_frame = options_.base_frame;
  in_base_frame.constraint = constraint;
  in_base_frame.constraint.query_id = loop.constraint.query_id;
  in_base_frame.constraint.match_id = loop.constraint.match_id;
  kept_.emplace_back(in_base_frame);
  ++kept_revision_;
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
    std::snprintf(earlier, sizeof(earlier), " (%zu earlier graph(s) dropped: time went back)",
                  graphs_dropped_);
  }
  char line[400];
  std::snprintf(line, sizeof(line),
                "Pose graph: %zu keyframes in %zu chain(s), %zu joined by loops to the first%s; "
                "%zu optimisations, median %.1f ms; odometry heading drift %s; loops:",
                graph_->keyframes(), graph_->chains(), graph_->chainsJoinedToFirst(), earlier,
                times.size(), median, drift);
  return line + loops;
}

}  // namespace landmark_loop_closure
