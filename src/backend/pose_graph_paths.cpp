// The uncertainty between two keyframes along the pose graph's most certain path, which screens
// loops before they enter and after each optimisation.
#include <functional>
#include <limits>
#include <queue>

#include "landmark_loop_closure/backend/pose_graph.h"

namespace landmark_loop_closure {

Eigen::Vector2d PoseGraph::pathVariance(size_t from, size_t to,
                                        std::optional<size_t> excluded) const {
  struct Step {
    size_t to;
    double translation_variance;
    double rotation_variance;
    double metres;
  };
  const size_t count = nodes_.size();
  std::vector<std::vector<Step>> steps(count);
  for (size_t j = 0; j < count; ++j) {
    const size_t i = nodes_[j].previous;
    if (i == kNone) continue;  // A chain's first keyframe.
    const Eigen::Matrix<double, 6, 1> sd = odometrySd(i, j);
    const double metres = (nodes_[j].odometry.position - nodes_[i].odometry.position).norm();
    const double translation = sd[0] * sd[0];
    const double rotation = sd[3] * sd[3];
    steps[i].push_back({j, translation, rotation, metres});
    steps[j].push_back({i, translation, rotation, metres});
  }
  for (size_t k = 0; k < loops_.size(); ++k) {
    if (!loops_[k].active || !loops_[k].optimised || (excluded && *excluded == k)) continue;
    const LoopConstraint& loop = loops_[k].constraint;
    const size_t a = *indexOf(loop.query_id);
    const size_t b = *indexOf(loop.match_id);
    const double translation = loop.translationVariance();
    const double rotation = loop.rotationVariance();
    steps[a].push_back({b, translation, rotation, 0.0});
    steps[b].push_back({a, translation, rotation, 0.0});
  }
  // Dijkstra on the translation variance; the rotation variance and length ride along.
  constexpr double kUnreached = std::numeric_limits<double>::infinity();
  std::vector<double> translation(count, kUnreached);
  std::vector<double> rotation(count, 0.0);
  std::vector<double> metres(count, 0.0);
  using Entry = std::pair<double, size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  translation[from] = 0.0;
  open.push({0.0, from});
  while (!open.empty()) {
    const auto [cost, node] = open.top();
    open.pop();
    if (cost > translation[node]) continue;
    if (node == to) break;
    for (const Step& step : steps[node]) {
      const double reached = cost + step.translation_variance;
      if (reached < translation[step.to]) {
        translation[step.to] = reached;
        rotation[step.to] = rotation[node] + step.rotation_variance;
        metres[step.to] = metres[node] + step.metres;
        open.push({reached, step.to});
      }
    }
  }
  // A heading error spread along the path moves its far end by about a third of the
  // length squared times the rotation variance.
  return {translation[to] + rotation[to] * metres[to] * metres[to] / 3.0, rotation[to]};
}

}  // namespace landmark_loop_closure
