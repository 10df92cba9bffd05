#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace landmark_loop_closure {

/// Counts, for each candidate match of the current keyframe, how many consecutive keyframes
/// (this one included) have matched the same stretch of the map: a candidate m extends the
/// chain of a candidate m' of the previous keyframe when |m - m'| <= index_window.
/// A loop is only believed once the chain is k keyframes long.
class TemporalConsistency {
 public:
  explicit TemporalConsistency(int index_window) : index_window_(index_window) {}

  /// `match_ids`: the candidates of this keyframe that passed the score threshold.
  /// Returns the chain length of each, in the same order.
  std::vector<int> update(const std::vector<uint64_t>& match_ids);

  /// Breaks every chain (a keyframe without a query, or a reset).
  void reset() { previous_chains_.clear(); }

 private:
  int index_window_;
  std::unordered_map<uint64_t, int> previous_chains_;  ///< match id -> chain length.
};

}  // namespace landmark_loop_closure
