// advanced/acceptance/max_false_alarms: whether a candidate may be believed, judged by how many
// wrong places are expected to score as high as it over the map (the tail of what the other
// places scored for the last few keyframes), with the rules for a candidate among the places the
// query has just passed, for one that continues the last published loop, and for one of the
// query's own run (it must have left the place). Its state is what those rules remember; the map,
// the descriptor and the sequence scores are the detector's, lent per call (DecisionContext).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/core/candidate_report.h"
#include "landmark_loop_closure/core/false_alarms.h"
#include "landmark_loop_closure/core/loop_detector_options.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// What the detector lends the decision for one keyframe.
struct DecisionContext {
  const KeyframeDatabase& database;
  const DescriptorExtractor& extractor;
  SequenceMatcher& sequences;  ///< Scores a place as a candidate would be scored.
  DetectorMode mode;
  uint32_t session;  ///< The query's.
};

class CalibratedDecision {
 public:
  /// `options`: acceptance (max_false_alarms, max_false_alarms_within_reach, place_window,
  /// index_window), odometry_gate, database (exclude_recent_keyframes, eligibility).
  explicit CalibratedDecision(const LoopDetectorOptions& options);

  /// On when max_false_alarms is, and the descriptor's final score is the global similarity the
  /// background is made of (no re-ranking).
  bool appliesTo(const DescriptorExtractor& extractor) const;

  /// Before the query's candidates are judged: what the map's other places score against it (its
  /// background, pooled with the last few keyframes'), and, mapping, what the places it has just
  /// passed score.
  void record(const KeyframeRecord& query, const DecisionContext& context);
  /// Whether so few wrong places are expected to score as high as `report` that it may be
  /// believed; sets its false_alarms, false_alarm_places and continues_loop, and its detail when
  /// not. True when the decision does not apply.
  bool passes(CandidateReport* report, const KeyframeRecord& query, const DecisionContext& context);
  /// The query published a loop to `match`: the next keyframe's candidate that continues it is
  /// one of the few places that would.
  void published(const KeyframeRecord& query, const KeyframeSummary& match, uint32_t session);
  /// Another map, mode or start: nothing remembered applies.
  void reset();

  /// Keyframes whose backgrounds are pooled.
  static constexpr size_t kPooledBackgrounds = 5;

 private:
  /// Whether `match` is among the places the query has just passed: E + 1 to 2E keyframes back in
  /// its own run (E = exclude_recent_keyframes).
  bool justPassed(const KeyframeSummary& match, uint64_t query_id, uint32_t session) const;
  /// Whether `match` continues the loop the keyframe before `query_id` published.
  bool continuesLastLoop(const KeyframeSummary& match, uint64_t query_id, uint32_t session) const;
  /// max_false_alarms, or max_false_alarms_within_reach where the odometry puts the match within
  /// its reach.
  double bound(const KeyframeSummary* match, const KeyframeRecord& query,
               const DecisionContext& context) const;
  /// Whether, between `match` and the query in the query's own run, some keyframe outside the
  /// match's place_window scores at most `level` as a candidate would (the query looked like an
  /// ordinary other place there): a revisit leaves the place and comes back, a slow stretch of
  /// look-alike frames never does. Says, in `detail`, the lowest score found when not.
  bool leftThePlace(const KeyframeSummary& match, double level, const DecisionContext& context,
                    std::string* detail) const;

  const AcceptanceOptions acceptance_;
  const OdometryGateOptions gate_;
  const DatabaseOptions database_options_;

  /// What one keyframe's wrong places scored (ids, sessions and scores); the last
  /// kPooledBackgrounds are pooled for the tail: one keyframe's sample of a small map is too thin
  /// to fit, and the map's look-alikes change slowly along a path.
  struct PlaceScore {
    uint64_t id = 0;
    uint32_t session = 0;
    double score = 0.0;
  };
  std::deque<std::vector<PlaceScore>> backgrounds_;
  size_t background_places_ = 0;  ///< Eligible places of the newest background.
  /// The places just passed: their scores, pooled over queries, are the tail a candidate among
  /// them must stand out of.
  PassedPlaceScores passed_places_;
  /// The loop the last keyframe published.
  struct PublishedLoop {
    uint64_t query_id = 0;
    uint32_t query_session = 0;
    uint64_t match_id = 0;
    uint32_t match_session = 0;
    /// It continued a loop on the same match or one behind it: the stretch stood while the
    /// query moved on.
    bool stood = false;
  };
  std::optional<PublishedLoop> last_loop_;
};

}  // namespace landmark_loop_closure
