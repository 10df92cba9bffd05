// The pose graph's chains: which chains the accepted loops join, and a joining loop placing the
// later chain before the solve (see PoseGraph::startChain).
#include <algorithm>

#include "landmark_loop_closure/backend/pose_graph.h"

namespace landmark_loop_closure {

std::optional<size_t> PoseGraph::chainOf(uint64_t id) const {
  const std::optional<size_t> index = indexOf(id);
  if (!index) return std::nullopt;
  return chainAt(*index);
}

std::vector<size_t> PoseGraph::chainGroups(bool optimised_only) const {
  std::vector<size_t> group(chains_.size());
  for (size_t c = 0; c < group.size(); ++c) group[c] = c;
  const auto root = [&group](size_t c) {
    while (group[c] != c) c = group[c];
    return c;
  };
  for (const LoopEdge& edge : loops_) {
    if (!edge.active || (optimised_only && !edge.optimised)) continue;
    const size_t a = root(chainAt(*indexOf(edge.constraint.query_id)));
    const size_t b = root(chainAt(*indexOf(edge.constraint.match_id)));
    // The smaller chain index is the group's name: the first chain's group is 0.
    group[std::max(a, b)] = std::min(a, b);
  }
  for (size_t c = 0; c < group.size(); ++c) group[c] = root(c);
  return group;
}

size_t PoseGraph::chainsJoinedToFirst() const {
  const std::vector<size_t> group = chainGroups(false);
  return static_cast<size_t>(std::count(group.begin(), group.end(), 0u));
}

size_t PoseGraph::placeJoinedChains() {
  std::vector<size_t> group = chainGroups(true);
  size_t first_moved = nodes_.size();
  for (const LoopEdge& edge : loops_) {
    if (!edge.active || edge.optimised) continue;
    const size_t query = *indexOf(edge.constraint.query_id);
    const size_t match = *indexOf(edge.constraint.match_id);
    const size_t query_group = group[chainAt(query)];
    const size_t match_group = group[chainAt(match)];
    if (query_group == match_group) continue;
    // The later group moves onto the loop (the first chain's never does), so that the solve
    // starts where this loop puts it, not where the chain floated.
    const bool move_query = query_group > match_group;
    const Eigen::Isometry3d moved_to =
        move_query ? estimate(match) * edge.constraint.query_T_match.inverse()
                   : estimate(query) * edge.constraint.query_T_match;
    const size_t moved_group = move_query ? query_group : match_group;
    const Eigen::Isometry3d correction = moved_to * estimate(move_query ? query : match).inverse();
    for (size_t i = 0; i < nodes_.size(); ++i) {
      if (group[chainAt(i)] != moved_group) continue;
      setEstimate(i, correction * estimate(i));
      first_moved = std::min(first_moved, i);
    }
    for (size_t& g : group) {
      if (g == moved_group) g = std::min(query_group, match_group);
    }
  }
  return first_moved;
}

}  // namespace landmark_loop_closure
