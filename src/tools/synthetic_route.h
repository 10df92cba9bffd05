#pragma once

// Synthetic global descriptors for the scaling benchmarks (lcd_bench_scaling, lcd_bench_map).
#include <cmath>
#include <random>
#include <vector>

namespace landmark_loop_closure {
namespace bench {

inline void normalise(std::vector<float>* values) {
  double norm = 0.0;
  for (const float v : *values) norm += static_cast<double>(v) * v;
  const double scale = norm > 0.0 ? 1.0 / std::sqrt(norm) : 0.0;
  for (float& v : *values) v = static_cast<float>(v * scale);
}

// Successive global descriptors along a route: x <- 0.9 x + 0.45 n keeps each dimension's
// variance steady and the cosine of neighbours near 0.9, falling to ~0.35 ten keyframes apart.
class Route {
 public:
  Route(int dimension, unsigned seed) : state_(static_cast<size_t>(dimension)), random_(seed) {
    for (float& v : state_) v = normal_(random_);
  }
  std::vector<float> next() {
    for (float& v : state_) v = 0.9f * v + 0.45f * normal_(random_);
    std::vector<float> unit = state_;
    normalise(&unit);
    return unit;
  }
  // `place` seen again: cosine ~0.9 to it.
  std::vector<float> revisit(const std::vector<float>& place) {
    const float sigma = std::sqrt(0.2346f / static_cast<float>(place.size()));
    std::vector<float> seen = place;
    for (float& v : seen) v += sigma * normal_(random_);
    normalise(&seen);
    return seen;
  }
  std::mt19937& random() { return random_; }

 private:
  std::vector<float> state_;
  std::mt19937 random_;
  std::normal_distribution<float> normal_;
};

}  // namespace bench
}  // namespace landmark_loop_closure
