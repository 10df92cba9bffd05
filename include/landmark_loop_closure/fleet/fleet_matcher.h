// Loops between robots (issue 68): a detector keeps the search rows other robots share as maps
// of their own, searches each of its keyframes in them, and checks a candidate with the same
// stages as its own loops: the score, the k-keyframe chain, then the verification of the place
// on the other keyframe's fetched keypoints (a loop between robots has no odometry between them:
// only a confirmed place is accepted).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/core/place_check.h"
#include "landmark_loop_closure/core/temporal_consistency.h"
#include "landmark_loop_closure/fleet/foreign_map.h"
#include "landmark_loop_closure/fleet/shared_keyframe.h"

namespace landmark_loop_closure {

struct FleetOptions {
  bool share = false;  ///< Publish this detector's rows and answer for its keyframes' evidence.
  std::string robot;   ///< This robot's name in the rows it shares; empty: the node's namespace.
  /// Other robots' detector namespaces, separated by spaces or commas: their rows are kept and
  /// searched. Empty: no loops between robots.
  std::string peers;
  /// A candidate's score (the best path mean with sequence_length > 1) needs at least this.
  double min_score = 0.1;
  /// Own keyframes per path (SeqSLAM-style, as advanced/acceptance/sequence_length); 1 = single
  /// keyframes' cosines.
  int sequence_length = 5;
  int consistent_keyframes = 3;  ///< Consecutive own keyframes matching one stretch of a map.
  int place_window = 10;         ///< Ids within which two matches are one place.
  /// Ids within which consecutive own keyframes' matches continue each other (the chain, a
  /// continuing loop, a place's best candidate against its neighbours).
  int index_window = 3;
  int top_k = 5;  ///< Candidates kept per keyframe over every other map.
  /// Rows of one map from which a search reads only the rows an HNSW graph finds nearest the
  /// last keyframes and a fixed sample of the map (0: every row, always).
  int approximate_from = 2000;
  int nearest_rows = 16;           ///< Rows the graph returns per own keyframe and map.
  int max_rows_per_robot = 20000;  ///< Rows kept of one robot (~90 MB); later ones are refused.
  int max_maps_per_robot = 32;     ///< Maps (map_ids) kept of one robot; rows of more are refused.
  double silent_after_s = 30.0;    ///< A robot whose rows stop this long is reported silent.
  double fetch_timeout_s = 2.0;    ///< A fetch of evidence unanswered this long is given up.
  /// Evidence requests answered a second per caller (all callers together: 4 times as many).
  double evidence_requests_per_s = 50.0;
  /// Rows a second sent to a peer that subscribes after they were shared (the map so far).
  double backlog_rows_per_s = 500.0;
  double min_place_ratio = 1.1;    ///< Score over the best other place's (0 = off).
  double max_false_alarms = 0.03;  ///< Expected wrong places as high (0 = off).
  /// The appearance check alone (ORB could not confirm the place) may confirm a loop between
  /// robots, as it does the detector's own (behind the calibrated decision above).
  bool appearance_confirms = true;

  /// Keys under fleet/, documented in config/default.yaml.
  static const ParameterTable<FleetOptions>& parameters();
  std::string validate() const;
  /// peers, split.
  std::vector<std::string> peerList() const;
  /// How each other map is searched.
  ForeignSearchOptions search() const;
};

/// A candidate of another robot's map that passed the score and the chain: its evidence is
/// fetched, then checkFleetCandidate() decides.
struct FleetCandidate {
  uint64_t query_map_id = 0;
  uint64_t query_id = 0;
  uint32_t query_session = 0;
  SharedKeyframe match;      ///< The other robot's row, its vector left out.
  std::string peer;          ///< The peer that shared the match's map: it answers for its evidence.
  double score = 0.0;        ///< The best path's mean cosine (the cosine with sequence_length 1).
  double place_ratio = 0.0;  ///< score over the best other place's (0: none scored).
  /// Wrong places of its map expected to score as high (max_false_alarms' estimate; -1: not
  /// tested, too few other places or the decision off).
  double false_alarms = -1.0;
  int consistent_keyframes = 0;
};

/// Per peer heard from (a subscription this detector chose): for bounds, diagnostics and the
/// silence lines.
struct FleetRobot {
  std::string peer;
  std::string robot;  ///< The name its first kept row gave; later rows must give the same.
  std::set<uint64_t> map_ids;
  size_t rows = 0;             ///< Kept and searched.
  size_t rows_refused = 0;     ///< Malformed, of another descriptor, or past max_rows_per_robot.
  size_t rows_repeated = 0;    ///< Already held (a peer that re-sends after a restart).
  size_t rows_past_bound = 0;  ///< Of rows_refused: past max_rows_per_robot.
  std::map<std::string, size_t> refusals;  ///< Of rows_refused, by reason (RowVerdict::reason).
  double last_heard_s = 0.0;
  bool silent = false;
};

/// What became of a row offered to the matcher.
struct RowVerdict {
  bool kept = false;   ///< Kept, or held already.
  std::string reason;  ///< Refused: a short fixed name of why ("robot name", "rows bound"...).
  std::string line;    ///< What to say, once a peer and reason ("" when nothing).
};

class FleetMatcher {
 public:
  /// Rows must be of `descriptor_identity` (its fingerprint) and `dimension` values.
  FleetMatcher(FleetOptions options, const std::string& descriptor_identity, int dimension);

  /// A row heard from `peer` (the subscription it came on) at `now_s`. The row is untrusted: it
  /// is validated whole (robot name, id range, lengths, finite values, descriptor) before it
  /// touches any state, its robot name must stay the one the peer's first kept row gave, its
  /// map must not be another peer's, and the peer's rows and maps are bounded
  /// (max_rows_per_robot, max_maps_per_robot). Rows of `own_map_id` (this detector's own,
  /// echoed back) are ignored. A peer that was silent also gets a line saying it is back.
  RowVerdict addRowFrom(const std::string& peer, const SharedKeyframe& row, double now_s,
                        uint64_t own_map_id);
  /// addRowFrom with the row's robot as its peer (one process: an evaluation, a benchmark);
  /// returns the line.
  std::string addRow(const SharedKeyframe& row, double now_s, uint64_t own_map_id);
  /// One of this detector's own keyframes (its own row): the other maps' rows scoring at least
  /// min_score, chained with the previous keyframes' matches; the best whose chain is long
  /// enough, if any. Call it for every own keyframe in order; several robots' keyframes may
  /// interleave (a fleet node), each (map, session) chaining its own.
  std::optional<FleetCandidate> query(const SharedKeyframe& own);
  /// Lines for robots that went silent since the last call (once each).
  std::vector<std::string> checkSilence(double now_s);

  std::vector<FleetRobot> robots() const;
  size_t rows() const;
  /// Chained candidates refused by min_place_ratio or max_false_alarms.
  size_t ambiguous() const { return ambiguous_; }
  /// Memory held by the rows (vectors and what a loop names).
  size_t bytes() const;
  const FleetOptions& options() const { return options_; }

 private:
  /// One of the querying run's last keyframes: its row and its cosines to each map's rows.
  struct QuerySlot {
    std::vector<uint8_t> row;
    std::map<uint64_t, KeyframeCosines> cosines;  ///< By map_id.
  };
  /// What one querying (map, session) remembers from keyframe to keyframe.
  struct QueryingRun {
    explicit QueryingRun(int index_window)
        : consistency(ConsistencyUnit::kKeyframes, index_window) {}
    TemporalConsistency consistency;
    std::deque<QuerySlot> history;  ///< Front: the newest keyframe.
    struct Candidate {
      uint64_t query_id = 0;
      uint64_t map_id = 0;
      uint64_t match_id = 0;
    };
    /// The latest keyframe's candidate, if it had one.
    std::optional<Candidate> last_candidate;
  };
  /// The run's newest keyframe's path scores over one map.
  MapScores pathScores(const ForeignMap& map, uint64_t map_id, QueryingRun* run) const;

  FleetOptions options_;
  uint64_t fingerprint_;
  std::string identity_;
  int dimension_;
  std::map<uint64_t, ForeignMap> maps_;       ///< By map_id.
  std::map<std::string, FleetRobot> robots_;  ///< By peer.
  /// By querying (map, session): each robot's run chains its own keyframes.
  std::map<std::pair<uint64_t, uint32_t>, QueryingRun> runs_;
  std::vector<double> speeds_;  ///< Path speeds tried (map keyframes per own keyframe).
  size_t ambiguous_ = 0;
};

/// The appearance check's cells of a thumbnail (a keyframe's, or a fetched one), computed on
/// demand by `detector`'s extractor; empty without one or a thumbnail. `detector` and
/// `thumbnail` must outlive the function.
CellsOfKeyframe thumbnailCellsOf(const LoopDetector& detector,
                                 const std::vector<uint8_t>& thumbnail);

/// Checks a fetched candidate against the own keyframe's keypoints, as the detector checks its
/// own loops (checkPlace), except that only a confirmed place passes (no odometry relates two
/// robots), by ORB unless `appearance_confirms`. Cameras may differ (lens, image size): the
/// match's keypoints are moved to the query camera's pixels first, which needs both intrinsics.
/// `false_alarms`: the candidate's (FleetCandidate::false_alarms), for the cells it needs.
PlaceCheck checkFleetCandidate(const GeometricVerifier& verifier,
                               const PlaceCheckSettings& settings, const LocalFeatures& query,
                               const CameraIntrinsics& query_intrinsics,
                               const KeyframeEvidence& match, const CellsOfKeyframe& query_cells_of,
                               const CellsOfKeyframe& match_cells_of, bool appearance_confirms,
                               double false_alarms = -1.0);

}  // namespace landmark_loop_closure
