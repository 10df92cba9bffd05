#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"

namespace landmark_loop_closure {
namespace eval {

/// One camera frame as the node hands it to the detector.
struct DetectorFrame {
  double stamp = 0.0;
  Pose pose;      ///< Odometry (or an index path): the keyframe rule and the odometry gate.
  cv::Mat image;  ///< Grey, or BGR for a descriptor that wants colour.
  CameraIntrinsics intrinsics;  ///< Invalid: loops go unverified (or are refused when required).
  /// The first frame of a later run (the next traversal): DetectorEvaluationOptions::protocol
  /// says what it starts.
  bool new_run = false;
};

/// Plays every frame in order into `sink` (index counts from 0). Called once per pass: the
/// threshold sweep replays the source.
using FramePlayer =
    std::function<void(const std::function<void(size_t index, const DetectorFrame&)>& sink)>;

/// The ground truth between two frames: query frame, earlier frame.
using SamePlace = std::function<bool(size_t query_frame, size_t match_frame)>;

struct PublishedLoop {
  uint64_t query_id = 0;
  uint64_t match_id = 0;
  size_t query_frame = 0;
  size_t match_frame = 0;
  double score = 0.0;
  bool verified = false;  ///< The geometric check confirmed it.
  bool correct = false;
  /// Its metric relative pose in the robot's base frame (turned with options.camera_mount), the
  /// edge a pose graph takes; absent for appearance-only and scale-free loops.
  std::optional<LoopConstraint> metric_pose;
};

/// One shortlisted candidate of a keyframe and what became of it (the configured pass only).
struct CandidateRow {
  uint64_t query_id = 0;
  uint64_t match_id = 0;
  size_t query_frame = 0;
  size_t match_frame = 0;
  double global_score = 0.0;
  double score = 0.0;
  std::string verdict;
  bool correct = false;
  double place_ratio = 0.0;    ///< CandidateReport::place_ratio.
  double false_alarms = -1.0;  ///< CandidateReport::false_alarms (-1: not tested).
  std::string detail;          ///< CandidateReport::detail: why it was refused, when said.
};

/// What the detector published at one advanced/acceptance/min_score.
struct DetectorPass {
  double min_score = 0.0;
  std::vector<PublishedLoop> loops;
  size_t true_loops = 0;
  double precision = 1.0;  ///< 1 when nothing was published.
  double recall = 0.0;     ///< True loops / revisited keyframes.
  /// Keyframes without a loop, by what stopped their best candidate ("below_threshold",
  /// "awaiting_consistency", "odometry_rejected", "geometry_rejected", "database_too_small",
  /// "all_excluded").
  std::map<std::string, size_t> refused;
  std::vector<double> keyframe_ms;  ///< The whole pipeline per keyframe (describe to decision).
  std::vector<CandidateRow> candidates;  ///< Every keyframe's shortlist (configured pass only).
};

struct DetectorEvaluation {
  size_t frames = 0;
  size_t keyframes = 0;
  size_t refused_frames = 0;  ///< Frames the detector refused as bad input.
  size_t revisits = 0;        ///< Keyframes with a true place among the earlier keyframes.
  std::vector<size_t> keyframe_frames;  ///< Frame index of each keyframe, by keyframe id.
  std::vector<Pose> keyframe_poses;     ///< Odometry pose of each keyframe, by keyframe id.
  /// The session of each keyframe, by keyframe id: its odometry frame (a new run, or the
  /// odometry re-initialised).
  std::vector<uint32_t> keyframe_sessions;
  DetectorPass configured;          ///< At the configuration's min_score: what the node publishes.
  std::vector<DetectorPass> sweep;  ///< Other thresholds, high to low.
  /// Best recall of a pass without a false loop; -1 when not swept (sweep_steps 0).
  double recall_at_100_precision = 0.0;
  double threshold_at_100_precision = 0.0;
  Percentiles keyframe_ms;  ///< Of the configured pass (descriptions computed there, not cached).
};

/// How the runs (traversals) of a replay meet: DetectorFrame::new_run.
enum class RunProtocol {
  kOneSequence,   ///< One session: every run continues the last (the image-only sequence).
  kSessions,      ///< Each run its own session, its odometry restarted at its first frame: loops
                  ///< into earlier runs skip the odometry gate, as loops into a loaded map do.
  kLocalisation,  ///< The runs before are the map: later runs are searched in it, nothing stored
                  ///< (mode localization).
  kOneRun,        ///< One session and one odometry throughout: the robot drives back to where the
                  ///< first run began (the odometry drifting on) and goes again, so loops into
                  ///< the earlier run meet the odometry gate.
  kRobots,        ///< Each run another robot, with a detector and a map of its own; the loops
                  ///< judged are those between robots (evaluateRobots).
};
const char* toString(RunProtocol protocol);
/// "one-sequence", "sessions", "localisation", "one-run" or "robots"; throws std::invalid_argument
/// otherwise.
RunProtocol runProtocol(const std::string& name);

struct DetectorEvaluationOptions {
  RunProtocol protocol = RunProtocol::kOneSequence;
  /// Thresholds on the grid (quantiles of the best candidate scores); 0 = the configured
  /// threshold alone, no sweep.
  int sweep_steps = 16;
  int refine_steps = 4;  ///< Bisections between the last clean and the first false threshold.
  FleetOptions fleet;    ///< kRobots: how robots search each other's rows.
};

/// Runs the frames through a LoopDetector built from `options` and `extractor`, once at the
/// configured advanced/acceptance/min_score and then at every threshold of the sweep (descriptions
/// are cached between passes, so a pass costs search and acceptance only). `same_place` judges the
/// published loops. Throws std::invalid_argument when the options are invalid.
DetectorEvaluation evaluateDetector(const LoopDetectorOptions& options,
                                    std::shared_ptr<const DescriptorExtractor> extractor,
                                    const FramePlayer& play, const SamePlace& same_place,
                                    const DetectorEvaluationOptions& evaluation = {},
                                    const Progress& progress = {});

/// kRobots: each run another robot (DetectorFrame::new_run); from the second on each keeps the
/// earlier robots' shared rows, searches its keyframes in them and checks a chained candidate on
/// the evidence of the robot that stored it, as the node's fleet link does. The pass holds the
/// loops between robots; revisits count the keyframes with a true place among earlier robots'.
/// Not swept (recall_at_100_precision -1). evaluateDetector() calls it for kRobots.
DetectorEvaluation evaluateRobots(const LoopDetectorOptions& options,
                                  std::shared_ptr<const DescriptorExtractor> extractor,
                                  const FramePlayer& play, const SamePlace& same_place,
                                  const FleetOptions& fleet);

/// Writes detector_<name>.json (every pass: threshold, loops, precision, recall, refusals) and
/// loops_<name>.csv (the configured pass's loops: ids, frames, score, verified, correct) and
/// candidates_<name>.csv (the configured pass's shortlists: scores, verdict, correct) into
/// `folder`. Returns the json's path.
std::string writeDetectorReport(const std::string& folder, const std::string& name,
                                const std::string& description, const DetectorEvaluation& result);

}  // namespace eval
}  // namespace landmark_loop_closure
