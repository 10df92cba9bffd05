// The loop detector's options: each stage's settings and the acceptance rules, as the node reads
// them (loop_detector.cpp declares their parameter tables).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/keyframe_selector.h"
#include "landmark_loop_closure/core/odometry_gate.h"
#include "landmark_loop_closure/core/score_normalisation.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/core/temporal_consistency.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/metric_pose.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// advanced/acceptance/min_score tuned for descriptor type landmarks (the package's own encoder).
constexpr double kLandmarksMinScore = 0.25;

struct AcceptanceOptions {
  /// Final similarity a candidate needs (in [-1, 1]; see default.yaml): with the calibrated
  /// decision a floor, without it (max_false_alarms 0, a re-ranking descriptor) the decision.
  double min_score = 0.1;
  /// A candidate is believed only where fewer non-loop places than this are expected to score as
  /// high over the map, from the tail of the query's scores against it (ScoreTail); 0 = off.
  double max_false_alarms = 0.003;
  /// The same bound for a candidate of the query's own session that the odometry puts within
  /// its reach (odometry gate on, mapping): the odometry is a second, independent witness.
  double max_false_alarms_within_reach = 0.3;
  /// kKeyframes: a loop needs consistent_keyframes consecutive keyframes whose matches agree
  /// within index_window ids; kMetres: the query must travel consistent_distance_m while its
  /// matches agree within match_window_m of path (see TemporalConsistency).
  ConsistencyUnit consistency_unit = ConsistencyUnit::kKeyframes;
  int consistent_keyframes = 3;  ///< k: consecutive keyframes that must agree on the place.
  int index_window = 3;          ///< Matches of consecutive keyframes agree within this many ids.
  /// Keyframes after a published loop within which a candidate may still continue it
  /// (continuesStretch): the calibrated decision counts only the places that would.
  int continue_across = 10;
  double consistent_distance_m = 0.6;  ///< Query travel the place must stay matched over.
  double match_window_m = 1.0;         ///< Matches agree within this (plus the query's step).
  /// A candidate's score over the best score of another place in the shortlist (placeRatios)
  /// must reach this; 0 = off.
  double min_place_ratio = 1.2;
  int place_window = 10;  ///< Candidates within this many ids of each other are one place.
  /// What a candidate's similarity is divided or standardised by before min_score (L = 1 only).
  ScoreNormalisation score_normalisation = ScoreNormalisation::kNone;
  int contrast_window = 10;  ///< local_contrast: map neighbours on each side of a candidate.
  /// Sequence matching (sequence_length > 1): the threshold applies to a candidate's best path
  /// mean over the last keyframes instead of its own score (SequenceMatcher).
  SequenceMatchingOptions sequence;

  /// Keys under acceptance/, documented in config/default.yaml.
  static const ParameterTable<AcceptanceOptions>& parameters();
  /// Acceptance rules measured and not kept (score normalisations, consistency in metres): not
  /// the node's parameters; lcd_evaluate --config reads them under their names of then
  /// ("acceptance/score_normalisation"), to reproduce bench/history.md.
  static const ParameterTable<AcceptanceOptions>& evaluationParameters();
  std::string validate() const;
};

/// mapping: every keyframe is searched and stored. localization: keyframes are only searched
/// (against a map built before) and nothing is added; the odometry gate is off, since the
/// current odometry need not share a frame or a drift history with the map's.
enum class DetectorMode { kMapping, kLocalization };

/// The parameter's words for each mode: "mapping", "localization".
const std::vector<std::pair<std::string, DetectorMode>>& detectorModeNames();
const char* toString(DetectorMode mode);

struct LoopDetectorOptions {
  DetectorMode mode = DetectorMode::kMapping;
  InputLimits input;
  KeyframeSelectorOptions keyframe;
  DescriptorOptions descriptor;
  DatabaseOptions database;
  AcceptanceOptions acceptance;
  OdometryGateOptions odometry_gate;
  VerificationOptions verification;
  AppearanceCheckOptions appearance;
  MetricPoseOptions metric_pose;
  /// Previous keyframes each keyframe's keypoints are triangulated against (the farther ones
  /// add baseline), when advanced/metric_pose/triangulate_from_odometry is on and no depth image
  /// came.
  int triangulation_keyframes = 3;
  /// The camera on the odometry's body frame: turns the odometry's motion between keyframes into
  /// the camera's.
  CameraMount camera_mount;
  bool keep_thumbnails = true;  ///< Keep a 160x120 grey copy of each keyframe for debug images.

  /// The detector's keys, documented in config/default.yaml: the ones a robot sets (`mode`,
  /// `camera_mount/*`), each in a table of its own so that the node's file can list them first, and
  /// every other one (under `advanced/`).
  static const ParameterTable<LoopDetectorOptions>& modeParameter();
  static const ParameterTable<LoopDetectorOptions>& mountParameters();
  static const ParameterTable<LoopDetectorOptions>& parameters();
  /// Empty when valid, otherwise every problem, one per line.
  std::string validate() const;
};

}  // namespace landmark_loop_closure
