#include "landmark_loop_closure/core/score_normalisation.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {

const std::vector<std::pair<std::string, ScoreNormalisation>>& scoreNormalisationNames() {
  static const std::vector<std::pair<std::string, ScoreNormalisation>> names = {
      {"none", ScoreNormalisation::kNone},
      {"previous_keyframe", ScoreNormalisation::kPreviousKeyframe},
      {"local_contrast", ScoreNormalisation::kLocalContrast},
      {"z_score", ScoreNormalisation::kZScore}};
  return names;
}

std::string toString(ScoreNormalisation normalisation) {
  for (const auto& [name, value] : scoreNormalisationNames()) {
    if (value == normalisation) return name;
  }
  return "unknown";
}

double previousKeyframeScore(double score, double previous) {
  if (score <= 0.0 || previous <= 0.0) return 0.0;
  return std::min(1.0, score / previous);
}

Standardisation Standardisation::of(const std::vector<double>& population) {
  Standardisation result;
  result.spread = 0.0;
  if (population.size() < 2) return result;
  double sum = 0.0;
  for (const double value : population) sum += value;
  const double mean = sum / static_cast<double>(population.size());
  double squares = 0.0;
  for (const double value : population) squares += (value - mean) * (value - mean);
  const double spread = std::sqrt(squares / static_cast<double>(population.size() - 1));
  result.mean = mean;
  if (spread > 1e-12) result.spread = spread;
  return result;
}

double standardisedScore(double score, const std::vector<double>& population) {
  return Standardisation::of(population).apply(score);
}

}  // namespace landmark_loop_closure
