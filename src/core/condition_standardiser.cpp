#include "landmark_loop_closure/core/condition_standardiser.h"

#include <cmath>

namespace landmark_loop_closure {

ConditionStandardiser::ConditionStandardiser(int window) : window_(window < 0 ? 0 : window) {}

void ConditionStandardiser::reset() {
  recent_.clear();
  sum_.clear();
}

std::vector<float> ConditionStandardiser::apply(const std::vector<float>& global) {
  if (!enabled() || global.empty()) return global;
  if (sum_.size() != global.size()) reset();
  if (sum_.empty()) sum_.assign(global.size(), 0.0);

  std::vector<float> added(global.size());
  for (size_t i = 0; i < global.size(); ++i) {
    added[i] = std::isfinite(global[i]) ? global[i] : 0.0f;
    sum_[i] += added[i];
  }
  recent_.push_back(added);
  if (recent_.size() > static_cast<size_t>(window_)) {
    const std::vector<float>& oldest = recent_.front();
    for (size_t i = 0; i < sum_.size(); ++i) sum_[i] -= oldest[i];
    recent_.pop_front();
  }
  return standardise(added);
}

std::vector<float> ConditionStandardiser::standardise(const std::vector<float>& global) const {
  if (!enabled()) return global;
  // Alone in its window, a vector has nothing to be told apart from. Kept raw it would carry what
  // every keyframe of its light shares and match them all; as zeros it matches nothing.
  const std::vector<float> nothing(global.size(), 0.0f);
  if (recent_.size() < 2 || global.size() != sum_.size()) return nothing;

  const double count = static_cast<double>(recent_.size());
  std::vector<float> standardised(global.size());
  double norm = 0.0;
  for (size_t i = 0; i < global.size(); ++i) {
    const double value = (std::isfinite(global[i]) ? global[i] : 0.0f) - sum_[i] / count;
    standardised[i] = static_cast<float>(value);
    norm += value * value;
  }
  // Rounding of the running sum leaves ~1e-7 per value where a vector equals the mean.
  if (!(norm > 1e-10)) return nothing;
  const float scale = static_cast<float>(1.0 / std::sqrt(norm));
  for (float& value : standardised) value *= scale;
  return standardised;
}

}  // namespace landmark_loop_closure
