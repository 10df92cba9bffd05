#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace landmark_loop_closure {

/// How a candidate's similarity is normalised by what the query resembles anyway, before it is
/// compared with advanced/acceptance/min_score (issue 35's experiments; bench/README.md has the
/// figures).
enum class ScoreNormalisation {
  kNone,              ///< The similarity itself.
  kPreviousKeyframe,  ///< DBoW2: over the query's similarity to the keyframe before it.
  kLocalContrast,     ///< SeqSLAM: standardised against the candidate's neighbours in the map.
  kZScore,            ///< Standardised against the query's similarity to the whole map.
};

/// z_score compares the query with at most this many map keyframes, spread evenly.
constexpr size_t kZScoreSample = 2000;

/// The parameter's words: "none", "previous_keyframe", "local_contrast", "z_score".
const std::vector<std::pair<std::string, ScoreNormalisation>>& scoreNormalisationNames();
/// Its parameter word.
std::string toString(ScoreNormalisation normalisation);

/// DBoW2's normalised score: `score / previous`, where `previous` is the query's similarity to
/// the keyframe before it (what "the same place" scores right now, in this light), capped at 1.
/// 0 when either is at or below 0: a query unlike its own predecessor says nothing.
double previousKeyframeScore(double score, double previous);

/// A query's similarities to the map summarised as their mean and standard deviation, so that
/// any one similarity can be told in spreads above what the query resembles anyway.
struct Standardisation {
  double mean = 0.0;
  double spread = 1.0;  ///< 0 where the population says nothing (then every score becomes 0).

  /// From a population of similarities; spread 0 with fewer than two values or no spread.
  static Standardisation of(const std::vector<double>& population);
  double apply(double score) const { return spread > 0.0 ? (score - mean) / spread : 0.0; }
};

/// (score - mean) / standard deviation of `population` (the candidate's own similarity included
/// or not, as the caller chooses): how many spreads the candidate stands above what the query
/// resembles anyway. 0 with fewer than two values or no spread.
double standardisedScore(double score, const std::vector<double>& population);

}  // namespace landmark_loop_closure
