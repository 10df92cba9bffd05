// What the detector says about each candidate of a keyframe: its scores and its verdict.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace landmark_loop_closure {

enum class CandidateVerdict {
  kAccepted,
  kBelowThreshold,       ///< score < min_score.
  kAwaitingConsistency,  ///< Above the threshold, fewer than k consistent keyframes so far.
  kOutscored,            ///< Consistent, but another candidate of this query scored higher.
  kOdometryRejected,     ///< Above the threshold, but the odometry cannot have drifted that far.
  kGeometryRejected,     ///< Consistent, but the geometric check refused it (see detail).
  kUnreadable,           ///< Its record could not be read from the map file (damaged).
  kAmbiguous,  ///< Above the threshold, but another place scored nearly as high (min_place_ratio).
};

const char* toString(CandidateVerdict verdict);

struct CandidateReport {
  uint64_t match_id = 0;
  double match_stamp = 0.0;
  double global_score = 0.0;  ///< Shortlist stage: cosine of the global descriptors.
  double score = 0.0;         ///< Final stage: the extractor's similarity, or the sequence's mean.
  double image_score = 0.0;   ///< This keyframe's own similarity (equals score without sequences).
  double place_ratio = 0.0;   ///< score over the best other place's (placeRatios).
  /// Non-loop places expected to score as high, over the map
  /// (advanced/acceptance/max_false_alarms); -1 when not tested.
  double false_alarms = -1.0;
  /// The places those were counted over: the map's that the odometry does not rule out, or the
  /// few that would continue the last keyframe's loop (0 when not tested).
  size_t false_alarm_places = 0;
  /// It continues the loop the keyframe before published (within acceptance/index_window) and
  /// keeps up with it: not behind its match, nor a second keyframe in a row on one match.
  bool continues_loop = false;
  int consistent_keyframes = 0;
  CandidateVerdict verdict = CandidateVerdict::kBelowThreshold;
  std::string detail;  ///< Why, when the verdict alone does not say (gate numbers, geometry).
  int inliers = 0;     ///< Geometric inliers, when the check ran.
};

}  // namespace landmark_loop_closure
