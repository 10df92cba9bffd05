// The pose_graph node's bookkeeping without ROS or threads: keyframes and loops, in the order they
// come, into the reference PoseGraph. A loop waits for its query keyframe (the detector may
// publish it first). Each (map, session) is a chain of its own (no odometry edge joins two
// odometry frames): a new chain floats, placed where the robot was last seen, until loops join it
// to the others; nothing is dropped at a new session or map, only when time goes back (a bag
// played again: another timeline). A loop the metric graph cannot take is left out with its
// reason. The node converts messages and publishes what it is told.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Geometry>

#include "landmark_loop_closure/backend/pose_graph.h"

namespace landmark_loop_closure {

/// A keyframe as the detector publishes it (Keyframe.msg).
struct GraphKeyframe {
  uint64_t id = 0;
  uint64_t map_id = 0;
  /// Keyframes of one session share one odometry frame (Keyframe.session: a new one after a map
  /// was loaded or the odometry re-initialised).
  uint32_t session = 0;
  Pose odometry;
  uint64_t stamp_ns = 0;
  std::string odometry_frame;
};

/// What the graph reads of a loop the detector publishes (LoopClosure.msg).
struct GraphLoop {
  uint64_t map_id = 0;  ///< The query keyframe's map.
  /// The match keyframe's map: another robot's for a loop between two maps; 0: map_id.
  uint64_t match_map_id = 0;
  uint64_t matchMap() const { return match_map_id != 0 ? match_map_id : map_id; }
  uint32_t query_session = 0;
  uint32_t match_session = 0;
  uint64_t query_stamp_ns = 0;
  uint64_t match_stamp_ns = 0;
  bool has_relative_pose = false;
  bool relative_pose_metric = false;
  std::string relative_pose_frame;
  /// The ids, query_T_match and its covariance, in relative_pose_frame.
  LoopConstraint constraint;
  /// A loop between robots: where the match robot's camera sits on its base
  /// (LoopClosure.match_camera_mount); its end of a camera-frame pose is turned by it.
  std::optional<Eigen::Isometry3d> match_camera_mount;
};

/// One decision about a loop (PoseGraphLoop.msg). A loop may get several: awaiting confirmation
/// then accepted, accepted then switched off.
struct GraphLoopVerdict {
  GraphLoop loop;
  std::string decision;  ///< toString(LoopDecision), or "left_out".
  double error_sd = 0.0;
  std::string detail;
};

/// A line for the log; its kind lets the node throttle each kind on its own.
struct GraphNotice {
  enum class Kind {
    kKeyframeDropped,  ///< Bad input: a warning, throttled.
    kNewGraph,         ///< A warning (time went back); `throttle` when the old graph held one
                       ///< keyframe.
    kNewChain,         ///< Info: another map or session started a chain of its own.
    kLoopBadInput,     ///< A warning, throttled.
    kLoopRefused,      ///< A warning.
    kLoopSwitchedOff,  ///< A warning.
    kLoopAwaiting,     ///< Debug.
  };
  Kind kind = Kind::kLoopRefused;
  std::string text;
  bool throttle = false;
};

/// base_frame <- `frame` (where the camera sits, or tf's answer); nullopt, with `problem` set,
/// when it is not known.
using MountLookup =
    std::function<std::optional<Eigen::Isometry3d>(const std::string& frame, std::string* problem)>;

/// What one batch of inputs did.
struct GraphStep {
  std::vector<GraphLoopVerdict> verdicts;  ///< In the order they were made.
  std::vector<GraphNotice> notices;
  bool changed = false;        ///< A keyframe or a loop entered: map -> odom may have moved.
  bool publish_paths = false;  ///< After an optimisation, a new graph or chain, every 10
                               ///< keyframes.
};

class PoseGraphSession {
 public:
  using Input = std::variant<GraphKeyframe, GraphLoop>;

  /// `mount` is asked for each loop frame other than options.base_frame; without one (empty),
  /// such loops are left out.
  PoseGraphSession(PoseGraphNodeOptions options, MountLookup mount);

  /// Everything that came meanwhile enters first; one optimisation then serves every new loop.
  GraphStep process(const std::vector<Input>& batch);

  /// The paths show the graph as it is now; true (once) when a new graph replaced the one they
  /// showed, whose refusals must then leave the view.
  bool pathsPublished();
  /// The graph holds keyframes the paths last published do not show.
  bool pathsBehind() const { return graph_->keyframes() != keyframes_in_paths_; }

  /// The graph numbers keyframes in the order they came (keyframes of several maps may share an
  /// id): graphId() and keyOf() translate.
  const PoseGraph& graph() const { return *graph_; }
  std::optional<uint64_t> graphId(uint64_t map_id, uint64_t id) const;
  /// (map_id, id) of a graph keyframe id.
  std::pair<uint64_t, uint64_t> keyOf(uint64_t graph_id) const { return keys_.at(graph_id); }
  /// The optimised pose of the detector's keyframe (map_id, id), nullopt when not in the graph.
  std::optional<Pose> optimisedPose(uint64_t map_id, uint64_t id) const;
  /// The chain of the newest keyframe: the one the robot is on now (its odometry frame).
  std::optional<size_t> currentChain() const;
  /// Each keyframe's stamp, in the graph's keyframe order.
  const std::vector<uint64_t>& stampsNs() const { return stamps_ns_; }
  /// The loops given to the graph, in its loop order (PoseGraph::loopVerdicts' indices), with the
  /// detector's ids.
  const std::vector<GraphLoop>& graphLoops() const { return graph_loops_; }
  /// map -> each odometry frame the keyframes came in (robots sharing the graph have one each):
  /// the correction at that frame's newest keyframe, by frame name.
  std::map<std::string, Eigen::Isometry3d> corrections() const;
  /// The odometry frame of the newest keyframe; empty before the first.
  const std::string& odometryFrame() const { return odometry_frame_; }
  /// One line: keyframes, optimisations and their median time, the heading drift, every
  /// decision and every reason for leaving a loop out, earlier maps' graphs included.
  std::string summary() const;

  /// The inputs that entered the graph, in the order they entered (loops turned into the base
  /// frame): what a saved graph holds.
  const std::vector<Input>& kept() const { return kept_; }
  /// Changes whenever kept() does (grows, or is emptied when time goes back).
  uint64_t keptRevision() const { return kept_revision_; }
  /// Replays saved inputs into this session (before any other): each keyframe with the loops
  /// after it, one batch each, as they came. Verdicts are not repeated; notices are.
  GraphStep restore(const std::vector<Input>& inputs);

  /// A (map, session): one odometry frame, one chain.
  using Run = std::pair<uint64_t, uint32_t>;

 private:
  bool addKeyframe(const GraphKeyframe& keyframe, GraphStep* step);
  void startOver(const GraphKeyframe& keyframe, GraphStep* step);
  /// Where a new chain's first keyframe is put: map -> odom of the robot as last seen.
  Eigen::Isometry3d newChainPlacement(const GraphKeyframe& keyframe, const char** how) const;
  bool addLoop(const GraphLoop& loop, GraphStep* step);

  static constexpr uint64_t kLoopWaitKeyframes = 10;
  static constexpr size_t kMaxWaitingLoops = 100;

  PoseGraphNodeOptions options_;
  MountLookup mount_;
  std::unique_ptr<PoseGraph> graph_;
  std::vector<GraphLoop> waiting_loops_;
  std::map<Run, size_t> chain_of_run_;
  std::map<std::pair<uint64_t, uint64_t>, uint64_t> graph_ids_;  ///< (map_id, id) -> graph id.
  std::vector<std::pair<uint64_t, uint64_t>> keys_;              ///< Graph id -> (map_id, id).
  std::map<uint64_t, uint64_t> last_id_of_map_;
  std::optional<Run> current_run_;                   ///< Of the newest keyframe.
  std::map<std::string, uint64_t> newest_in_frame_;  ///< Graph id, by odometry frame.
  std::string odometry_frame_;
  std::vector<uint64_t> stamps_ns_;
  std::map<uint64_t, uint64_t> last_stamp_of_map_;
  const bool fleet_;  ///< Several robots (options.robots): time is compared within a map.
  std::vector<GraphLoop> graph_loops_;
  std::vector<Input> kept_;
  uint64_t kept_revision_ = 0;
  std::map<std::string, size_t> left_out_;
  std::map<std::string, size_t> earlier_decisions_;  ///< Of the graphs of earlier maps.
  size_t graphs_dropped_ = 0;
  bool paths_stale_ = false;       ///< A new graph: its paths replace the old one's at once.
  size_t keyframes_in_paths_ = 0;  ///< In the paths last published.
  std::vector<double> optimisation_ms_;
};

}  // namespace landmark_loop_closure
