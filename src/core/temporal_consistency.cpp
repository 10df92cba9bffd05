#include "landmark_loop_closure/core/temporal_consistency.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {

const std::vector<std::pair<std::string, ConsistencyUnit>>& consistencyUnitNames() {
  static const std::vector<std::pair<std::string, ConsistencyUnit>> names = {
      {"keyframes", ConsistencyUnit::kKeyframes}, {"metres", ConsistencyUnit::kMetres}};
  return names;
}

bool parseConsistencyUnit(const std::string& text, ConsistencyUnit* unit) {
  for (const auto& [name, value] : consistencyUnitNames()) {
    if (name == text) {
      *unit = value;
      return true;
    }
  }
  return false;
}

bool TemporalConsistency::extends(const PathPoint& match, const PathPoint& previous,
                                  double query_step) const {
  if (unit_ == ConsistencyUnit::kKeyframes) {
    const uint64_t gap = match.id > previous.id ? match.id - previous.id : previous.id - match.id;
    return static_cast<double>(gap) <= window_;
  }
  return std::abs(match.metres - previous.metres) <= window_ + query_step;
}

std::vector<TemporalConsistency::Chain> TemporalConsistency::update(
    const PathPoint& query, const std::vector<PathPoint>& matches) {
  const double query_step = std::max(0.0, query.metres - previous_query_metres_);
  std::vector<Chain> chains;
  chains.reserve(matches.size());
  std::vector<Link> current;
  current.reserve(matches.size());
  for (const PathPoint& match : matches) {
    Chain chain;
    for (const Link& previous : previous_) {
      if (!extends(match, previous.match, query_step)) continue;
      chain.keyframes = std::max(chain.keyframes, previous.chain.keyframes + 1);
      chain.metres = std::max(chain.metres, previous.chain.metres + query_step);
    }
    chains.push_back(chain);
    current.push_back({match, chain});
  }
  previous_ = std::move(current);
  previous_query_metres_ = query.metres;
  return chains;
}

}  // namespace landmark_loop_closure
