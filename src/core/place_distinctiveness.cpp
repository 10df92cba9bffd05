#include "landmark_loop_closure/core/place_distinctiveness.h"

#include <algorithm>
#include <limits>

namespace landmark_loop_closure {

std::vector<double> placeRatios(
    const std::vector<ShortlistEntry>& shortlist, uint64_t window,
    const std::function<bool(size_t a, size_t b)>& could_be_same_place) {
  std::vector<double> ratios(shortlist.size(), 0.0);
  if (shortlist.empty()) return ratios;
  double lowest = std::numeric_limits<double>::infinity();
  for (const ShortlistEntry& entry : shortlist) lowest = std::min(lowest, entry.score);
  for (size_t i = 0; i < shortlist.size(); ++i) {
    const ShortlistEntry& candidate = shortlist[i];
    double competitor = -std::numeric_limits<double>::infinity();
    bool found = false;
    for (size_t j = 0; j < shortlist.size(); ++j) {
      const ShortlistEntry& other = shortlist[j];
      if (j == i || other.session != candidate.session) continue;
      if (sameIdPlace(other.id, other.session, candidate.id, candidate.session, window)) continue;
      if (could_be_same_place && could_be_same_place(i, j)) continue;
      competitor = std::max(competitor, other.score);
      found = true;
    }
    if (!found) competitor = lowest;
    if (candidate.score <= 0.0) {
      ratios[i] = 0.0;
    } else if (competitor <= 0.0) {
      ratios[i] = std::numeric_limits<double>::infinity();
    } else {
      ratios[i] = candidate.score / competitor;
    }
  }
  return ratios;
}

}  // namespace landmark_loop_closure
