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

double previousKeyframeScore(double score, double previous) {
  if (score <= 0.0 || previous <= 0.0) return 0.0;
  return std::min(1.0, score / previous);
}

double standardisedScore(double score, const std::vector<double>& population) {
  if (population.size() < 2) return 0.0;
  double sum = 0.0;
  for (const double value : population) sum += value;
  const double mean = sum / static_cast<double>(population.size());
  double squares = 0.0;
  for (const double value : population) squares += (value - mean) * (value - mean);
  const double spread = std::sqrt(squares / static_cast<double>(population.size() - 1));
  if (!(spread > 1e-12)) return 0.0;
  return (score - mean) / spread;
}

}  // namespace landmark_loop_closure
