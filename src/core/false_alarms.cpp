#include "landmark_loop_closure/core/false_alarms.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace landmark_loop_closure {

ScoreTail fitScoreTail(std::vector<double> scores, double tail_fraction) {
  ScoreTail tail;
  const size_t n = scores.size();
  if (n < ScoreTail::kMinSamples) return tail;
  size_t in_tail = static_cast<size_t>(std::ceil(std::clamp(tail_fraction, 0.0, 1.0) * n));
  in_tail = std::clamp<size_t>(in_tail, ScoreTail::kMinTail, n - 1);
  // The in_tail highest first, then u, the next one down.
  std::nth_element(scores.begin(), scores.begin() + in_tail, scores.end(), std::greater<>());
  const double threshold = scores[in_tail];
  double excess = 0.0;
  for (size_t i = 0; i < in_tail; ++i) excess += std::max(0.0, scores[i] - threshold);
  tail.samples = n;
  tail.threshold = threshold;
  tail.tail_fraction = static_cast<double>(in_tail) / static_cast<double>(n);
  tail.mean_excess = std::max(ScoreTail::kMinMeanExcess, excess / static_cast<double>(in_tail));
  return tail;
}

double ScoreTail::exceedance(double score) const {
  if (!valid()) return 1.0;
  if (score <= threshold) return 1.0;  // At or below the tail: as common as the tail or more.
  return tail_fraction * std::exp(-(score - threshold) / mean_excess);
}

double ScoreTail::expectedFalseAlarms(double score, size_t places) const {
  return static_cast<double>(places) * exceedance(score);
}

double ScoreTail::scoreFor(double false_alarms, size_t places) const {
  if (!valid() || places == 0 || !(false_alarms > 0.0)) return HUGE_VAL;
  const double share = false_alarms / static_cast<double>(places);
  if (share >= tail_fraction) return threshold;
  return threshold + mean_excess * std::log(tail_fraction / share);
}

void PassedPlaceScores::add(std::vector<double> scores) {
  if (scores.empty()) return;
  queries_.push_front(std::move(scores));
  while (queries_.size() > kQueries) queries_.pop_back();
}

size_t PassedPlaceScores::samples() const {
  size_t count = 0;
  for (const std::vector<double>& scores : queries_) count += scores.size();
  return count;
}

ScoreTail PassedPlaceScores::tail() const {
  if (samples() < kMinSamples) return {};
  std::vector<double> pooled;
  pooled.reserve(samples());
  for (const std::vector<double>& scores : queries_) {
    pooled.insert(pooled.end(), scores.begin(), scores.end());
  }
  return fitScoreTail(std::move(pooled));
}

}  // namespace landmark_loop_closure
