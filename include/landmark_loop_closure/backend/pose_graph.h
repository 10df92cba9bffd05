#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// The reference pose-graph backend: keyframe poses from odometry, odometry edges between
/// consecutive keyframes of one chain (a run's odometry frame), loop edges from the detector's
/// metric relative poses, within a chain or joining two. Optimised with Ceres (6 DoF, the first
/// keyframe held fixed, and the first of each chain no loop joins to it yet); wrong loops are
/// screened before they enter and switched off when the optimised graph disagrees with them.
struct PoseGraphOptions {
  /// Odometry edge uncertainty (one standard deviation): a floor plus a share of the motion.
  double odometry_translation_sd_m = 0.01;
  double odometry_translation_sd_per_m = 0.05;
  double odometry_rotation_sd_rad = 0.002;
  double odometry_rotation_sd_per_m = 0.01;
  double odometry_rotation_sd_per_rad = 0.05;
  /// The odometry's heading may drift at a steady rate (radians per metre travelled, about the
  /// body's z axis, as visual odometry and wheel odometry do): the graph estimates that rate from
  /// the loops, with this prior standard deviation around zero. 0: not estimated.
  double heading_drift_prior_sd_per_m = 0.01;
  /// Loop screening and switching off: a loop whose error, in standard deviations of the
  /// uncertainty between its two keyframes (odometry along the graph's most certain path plus the
  /// loop's own), exceeds this is refused.
  double max_loop_error_sd = 3.0;
  /// Cauchy loss scale on loop residuals (in standard deviations): a wrong loop that passed the
  /// screening pulls with bounded force.
  double loop_loss_scale = 1.0;
  /// Pairwise consistency (PCM's test, on small groups): a loop that passed the screening enters
  /// only once this many other loops nearby agree with it: both their ends within
  /// confirmation_distance_m of its own along the odometry, and the cycle the two loops close
  /// with the odometry between their ends within max_loop_error_sd (a partner the screening
  /// refused counts too: the pair test does not use the long path that refused it). A wrong
  /// loop seldom finds a partner; a true one waits for the next loop of its revisit. 0: each
  /// loop on its own.
  int loop_confirmations = 1;
  double confirmation_distance_m = 10.0;
  int max_iterations = 50;

  /// Keys under pose_graph/, documented in config/pose_graph.yaml.
  static const ParameterTable<PoseGraphOptions>& parameters();
  std::string validate() const;
};

/// A loop constraint: T_query_match (x_query = R x_match + t) in the robot's base frame, with
/// its 6x6 covariance ordered (x, y, z, rotation about x, y, z) for the error t' = t + dt,
/// R' = exp(w) R, both in the query's frame (LoopClosure.msg's convention).
struct LoopConstraint {
  uint64_t query_id = 0;
  uint64_t match_id = 0;
  Eigen::Isometry3d query_T_match = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();

  /// The covariance's mean variance per axis: translation (m^2) and rotation (rad^2).
  double translationVariance() const { return covariance.block<3, 3>(0, 0).trace() / 3.0; }
  double rotationVariance() const { return covariance.block<3, 3>(3, 3).trace() / 3.0; }
};

/// Turns a loop expressed in the camera's optical frame into the base frame, given where the
/// camera sits on the base (base_T_camera); the covariance follows to first order.
LoopConstraint loopInBaseFrame(const LoopConstraint& camera_loop,
                               const Eigen::Isometry3d& base_T_camera);
/// The same between two robots whose cameras sit at different mounts: the query's camera on the
/// query's base, the match's on the match's (loopBetweenBodies).
LoopConstraint loopInBaseFrames(const LoopConstraint& camera_loop,
                                const Eigen::Isometry3d& query_base_T_camera,
                                const Eigen::Isometry3d& match_base_T_camera);

enum class LoopDecision {
  kAccepted,
  kUnknownKeyframe,       ///< Query or match not in the graph (yet).
  kBadCovariance,         ///< Not finite, not symmetric positive definite.
  kBadPose,               ///< Relative pose not finite, or its rotation block not a rotation.
  kInconsistent,          ///< Disagrees with the graph by more than max_loop_error_sd.
  kSwitchedOff,           ///< Accepted, then contradicted by the optimised graph.
  kAwaitingConfirmation,  ///< Passed the screening; no loop nearby has agreed with it yet.
};
std::string toString(LoopDecision decision);

struct LoopVerdict {
  LoopDecision decision = LoopDecision::kAccepted;
  double error_sd = 0.0;  ///< Its error in standard deviations when it was screened.
  std::string detail;
  /// Earlier loops (indices) that were awaiting confirmation and entered with this one.
  std::vector<size_t> confirmed;
};

struct OptimisationReport {
  bool ran = false;  ///< False when there was nothing new to solve.
  double milliseconds = 0.0;
  std::vector<uint64_t> switched_off;  ///< Loop indices switched off by this optimisation.
};

class PoseGraph {
 public:
  /// `map_from_odometry` places the first keyframe (held) at that correction of its odometry
  /// pose: a graph that continues where another one's correction left off.
  explicit PoseGraph(PoseGraphOptions options = {},
                     const Eigen::Isometry3d& map_from_odometry = Eigen::Isometry3d::Identity());
  ~PoseGraph();
  PoseGraph(const PoseGraph&) = delete;
  PoseGraph& operator=(const PoseGraph&) = delete;

  /// Adds a keyframe at its odometry pose to the last chain; ids must increase. Its estimate
  /// starts at the last keyframe's estimate moved by the odometry between them. Returns why it
  /// was refused, or "".
  std::string addKeyframe(uint64_t id, const Pose& odometry_pose);
  /// Starts another chain with this keyframe: an odometry frame no odometry edge joins to the
  /// others (another run, the odometry re-initialised). It floats, its first keyframe held at
  /// `map_from_odometry` times its odometry pose, until an accepted loop joins it to the rest:
  /// the optimisation then moves it whole onto that loop first. Returns why it was refused, or "".
  std::string startChain(uint64_t id, const Pose& odometry_pose,
                         const Eigen::Isometry3d& map_from_odometry);
  /// Adds a keyframe to chain `chain` (chains are numbered as they start, the first 0): chains
  /// may interleave (robots sharing one graph). Returns why it was refused, or "".
  std::string addToChain(size_t chain, uint64_t id, const Pose& odometry_pose);
  /// Why addKeyframe would refuse this odometry pose whatever the graph holds, or "".
  static std::string odometryPoseProblem(uint64_t id, const Pose& odometry_pose);

  /// Screens a loop against the graph's current estimate and, once confirmed by other loops
  /// (loop_confirmations), keeps it. Loops are numbered in the order they are given (the index
  /// the report's switched_off and a verdict's confirmed use); loopVerdicts() holds each one's
  /// latest decision.
  LoopVerdict addLoop(const LoopConstraint& loop);

  /// Optimises every keyframe pose; loops the result contradicts are switched off and the graph
  /// optimised again without them (at most a few rounds).
  OptimisationReport optimise();

  size_t keyframes() const { return ids_.size(); }
  size_t chains() const { return chains_.size(); }
  /// The chain of keyframe `id` (0 for the first), nullopt when it is not in the graph.
  std::optional<size_t> chainOf(uint64_t id) const;
  /// Chains the accepted loops join to the first one (the first counted).
  size_t chainsJoinedToFirst() const;
  bool hasKeyframe(uint64_t id) const { return indexOf(id).has_value(); }
  size_t loops() const { return loops_.size(); }
  size_t activeLoops() const;
  const std::vector<LoopVerdict>& loopVerdicts() const { return verdicts_; }

  const std::vector<uint64_t>& ids() const { return ids_; }
  std::optional<Pose> odometryPose(uint64_t id) const;
  std::optional<Pose> optimisedPose(uint64_t id) const;
  /// map_T_odom: the correction that takes the newest keyframe's odometry frame onto the
  /// optimised one at that keyframe (the one it was built with before any keyframe).
  Eigen::Isometry3d mapFromOdometry() const;
  /// The odometry's heading drift the graph has estimated (rad per metre; 0 when not estimated).
  double headingDriftPerMetre() const { return heading_drift_per_m_; }

 private:
  struct Node {
    Pose odometry;
    size_t chain = 0;
    size_t previous = kNone;        ///< Its chain's keyframe before it (an odometry edge).
    double metres_travelled = 0.0;  ///< Along the odometry from its chain's first keyframe.
    double position[3];
    double orientation[4];  ///< x, y, z, w (Eigen's storage order).
  };
  struct LoopEdge {
    LoopConstraint constraint;
    Eigen::Matrix<double, 6, 6> sqrt_information;
    bool active = true;
    /// The estimate has been optimised with it: only then does it shorten the paths that
    /// screen later loops (the estimate does not agree with a loop it has not seen).
    bool optimised = false;
    int agreements = 0;  ///< Other loops nearby that agree with it.
  };

  static constexpr size_t kNone = static_cast<size_t>(-1);
  struct Chain {
    size_t first = 0;  ///< Node indices.
    size_t last = 0;
  };
  /// To `chain`, or to a new chain placed at `new_chain_from_odometry` when it is kNone.
  std::string addNode(uint64_t id, const Pose& odometry_pose, size_t chain,
                      const Eigen::Isometry3d& new_chain_from_odometry);
  std::optional<size_t> indexOf(uint64_t id) const;
  size_t chainAt(size_t index) const { return nodes_[index].chain; }
  /// For each chain, the first chain of the group the loops `use` (active ones, and optimised ones
  /// when `optimised_only`) join it to.
  std::vector<size_t> chainGroups(bool optimised_only) const;
  /// Moves the groups a loop new to the estimate joins onto that loop (the later group onto the
  /// one of the first chain, or of the earlier chain); returns the first keyframe moved, or
  /// nodes_.size().
  size_t placeJoinedChains();
  Eigen::Isometry3d estimate(size_t index) const;
  void setEstimate(size_t index, const Eigen::Isometry3d& pose);
  /// With the drift estimated: the keyframes no loop reaches are placed again (see there).
  void replaceUnloopedStart();
  Eigen::Matrix<double, 6, 1> odometrySd(size_t from, size_t to) const;
  /// The odometry's motion to keyframe `index` from the one before it in its chain, its
  /// estimated heading drift taken out.
  Eigen::Isometry3d odometryStep(size_t index) const;
  /// Variance per axis (translation m^2, rotation rad^2) of the relative pose between two
  /// keyframes along the graph's most certain path: odometry edges and active, optimised loops,
  /// `excluded` left out; the rotation's variance also moves the far end by the path's length.
  Eigen::Vector2d pathVariance(size_t from, size_t to, std::optional<size_t> excluded) const;
  struct LoopCheck {
    double error_sd = 0.0;
    std::string detail;
  };
  /// A loop's error against the current estimate, in standard deviations of the path's and its
  /// own uncertainty; nullopt when a keyframe is not in the graph.
  std::optional<LoopCheck> check(const LoopConstraint& loop, std::optional<size_t> excluded) const;
  /// Finds the loops nearby that agree with loops_[index] (see loop_confirmations), counts the
  /// agreement on both sides, and lets in those awaiting confirmation that reach
  /// loop_confirmations (reported in `verdict`): loops_[index] itself only if it passed the
  /// screening.
  void confirm(size_t index, LoopVerdict* verdict);
  /// The error, in standard deviations, of the cycle two loops close with the odometry between
  /// their queries and between their matches.
  double pairError(const LoopConstraint& a, const LoopConstraint& b) const;
  /// The odometry's motion from keyframe `from` to `to`, its heading drift taken out, with the
  /// variance per axis (translation, rotation) and the distance it covers.
  struct OdometryLeg {
    Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
    double translation_variance = 0.0;
    double rotation_variance = 0.0;
    double metres = 0.0;
  };
  OdometryLeg odometryLeg(size_t from, size_t to) const;
  /// One Ceres solve; keyframes before `first_free` are held. False when nothing was solved.
  bool solve(size_t first_free, OptimisationReport* report);

  PoseGraphOptions options_;
  Eigen::Isometry3d initial_map_from_odometry_;
  std::vector<uint64_t> ids_;
  std::vector<Node> nodes_;
  std::vector<Chain> chains_;
  std::vector<LoopEdge> loops_;
  std::vector<LoopVerdict> verdicts_;
  double heading_drift_per_m_ = 0.0;  ///< A Ceres parameter block of one.
};

}  // namespace landmark_loop_closure

namespace landmark_loop_closure {

/// Everything the pose_graph node reads, documented in config/pose_graph.yaml.
struct PoseGraphNodeOptions {
  std::string map_frame = "map";
  std::string base_frame = "base_link";
  bool publish_tf = true;
  double tf_rate_hz = 20.0;
  double tf_future_s = 0.1;
  /// The detector node whose camera_mount (values and from_tf) and base_frame the node takes
  /// from the parameter server, so the mount is set in one place for both; empty: the values
  /// below.
  std::string detector = "loop_closure";
  /// The detector's base_frame, when known (read from its parameters, not a parameter here): a
  /// loop in that frame is never taken for the camera's.
  std::string detector_base_frame;
  /// Where the graph is saved and restored from: beside the detector's map (its database_path
  /// followed by "-pose_graph", read from its parameters, not a parameter here); empty: not
  /// saved.
  std::string graph_file;
  /// Several robots' detector namespaces, separated by spaces or commas; empty: one detector.
  std::string robots;
  /// robots, split.
  std::vector<std::string> robotList() const;
  /// Loops in the camera's optical frame (the detector's default relative_pose_frame) are
  /// turned into the base frame with the mount.
  CameraMount camera_mount;
  /// Turn loops in any frame but base_frame through tf (base_frame <- the loop's
  /// relative_pose_frame, latest) instead of camera_mount.
  bool camera_mount_from_tf = false;
  /// No camera_mount value set and from_tf off: tf's mount where tf has it, the default values
  /// otherwise (as the detector does).
  bool mountFromTfWhereKnown() const { return !camera_mount_from_tf && camera_mount.isDefault(); }
  PoseGraphOptions graph;

  static const ParameterTable<PoseGraphNodeOptions>& parameters();
  std::string validate() const;
};

/// config/pose_graph.yaml as the declarations render it (a test compares the two).
std::string poseGraphDefaultsYaml();

}  // namespace landmark_loop_closure
