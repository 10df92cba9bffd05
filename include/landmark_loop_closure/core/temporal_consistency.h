#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace landmark_loop_closure {

/// How the temporal consistency check measures "the same stretch of the map, for long enough".
enum class ConsistencyUnit {
  kKeyframes,  ///< Chains of consecutive keyframes; matches agree within a number of ids.
  kMetres,     ///< Chains measured by the query's travelled path; matches agree within metres.
};

/// The parameter's words for each unit: "keyframes", "metres".
const std::vector<std::pair<std::string, ConsistencyUnit>>& consistencyUnitNames();
/// Parses "keyframes" or "metres"; false for anything else.
bool parseConsistencyUnit(const std::string& text, ConsistencyUnit* unit);

/// A keyframe's place along the robot's path: its id and the odometry path travelled up to it.
struct PathPoint {
  uint64_t id = 0;
  double metres = 0.0;
};

/// Counts, for each candidate match of the current keyframe, how long consecutive keyframes (this
/// one included) have matched the same stretch of the map. A candidate m extends the chain of a
/// candidate m' of the previous keyframe when they are close:
/// - kKeyframes: |id(m) - id(m')| <= window;
/// - kMetres: |metres(m) - metres(m')| <= window + the query's travel since the previous keyframe
///   (the match moves along the old path as fast as the query moves along the new one).
/// A loop is only believed once the chain is long enough (k keyframes, or a travelled distance).
class TemporalConsistency {
 public:
  struct Chain {
    int keyframes = 1;    ///< Consecutive keyframes in the chain, this one included.
    double metres = 0.0;  ///< Query path travelled since the chain's first keyframe.
  };

  TemporalConsistency(ConsistencyUnit unit, double window) : unit_(unit), window_(window) {}

  /// `matches`: the candidates of this keyframe that passed the score threshold. Returns the chain
  /// of each, in the same order.
  std::vector<Chain> update(const PathPoint& query, const std::vector<PathPoint>& matches);

  /// Breaks every chain (a keyframe without a query, or a reset).
  void reset() { previous_.clear(); }

 private:
  struct Link {
    PathPoint match;
    Chain chain;
  };

  bool extends(const PathPoint& match, const PathPoint& previous, double query_step) const;

  ConsistencyUnit unit_;
  double window_;
  std::vector<Link> previous_;
  double previous_query_metres_ = 0.0;
};

}  // namespace landmark_loop_closure
