#include "landmark_loop_closure/temporal_consistency.h"

#include <algorithm>

namespace landmark_loop_closure {

std::vector<int> TemporalConsistency::update(const std::vector<uint64_t>& match_ids) {
  std::vector<int> chains;
  chains.reserve(match_ids.size());
  std::unordered_map<uint64_t, int> current;
  for (const uint64_t match : match_ids) {
    int longest_previous = 0;
    for (const auto& [previous_match, length] : previous_chains_) {
      const uint64_t gap = match > previous_match ? match - previous_match : previous_match - match;
      if (gap <= static_cast<uint64_t>(index_window_)) {
        longest_previous = std::max(longest_previous, length);
      }
    }
    const int chain = longest_previous + 1;
    chains.push_back(chain);
    int& stored = current[match];
    stored = std::max(stored, chain);
  }
  previous_chains_ = std::move(current);
  return chains;
}

}  // namespace landmark_loop_closure
