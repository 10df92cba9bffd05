#pragma once

#include <cstddef>
#include <deque>
#include <vector>

namespace landmark_loop_closure {

/// The upper tail of what places that are not the query's score against it, fitted per query
/// (an a-contrario decision): a score is believed when so few non-loop places would reach it
/// that the expected number of false alarms over the whole map stays under a bound. A map whose
/// places look alike (a corridor of identical bays, a forest) has a heavy tail and needs more; a
/// varied route needs less: the threshold calibrates itself to the map it runs in.
///
/// Model: the scores above the tail's threshold u (the top `tail_fraction` of the sample, at
/// least kMinTail scores) exceed it by an exponential amount with mean `mean_excess` (the
/// peaks-over-threshold model with shape 0, which bounds a light, Gaussian-like tail from above:
/// it errs towards refusing).
struct ScoreTail {
  static constexpr size_t kMinSamples = 20;  ///< Fewer scores: nothing to calibrate on.
  static constexpr size_t kMinTail = 5;      ///< Scores the excess's mean is taken over.
  /// The excess's mean is at least this: a sample of equal scores must not make every score
  /// above them infinitely unlikely.
  static constexpr double kMinMeanExcess = 0.01;

  size_t samples = 0;          ///< Scores fitted (0: too few, not valid).
  double threshold = 0.0;      ///< u: the highest score below the tail.
  double tail_fraction = 0.0;  ///< Share of the sample above u.
  double mean_excess = 0.0;    ///< Mean of (score - u) over the tail.

  bool valid() const { return samples > 0; }
  /// Probability that a non-loop place scores at least `score` (the empirical share below u).
  double exceedance(double score) const;
  /// Expected number of non-loop places scoring at least `score` among `places` searched.
  double expectedFalseAlarms(double score, size_t places) const;
  /// The score at which `places` searched expect `false_alarms` non-loop places at or above it.
  double scoreFor(double false_alarms, size_t places) const;
};

/// Fits the tail of `scores` (any order; taken by value and partially sorted). Invalid when
/// fewer than kMinSamples.
ScoreTail fitScoreTail(std::vector<double> scores, double tail_fraction = 0.1);

/// What the places just passed (the query's own run, just beyond the exclusion window) scored
/// against the last kQueries queries. Along a route, places a few dozen keyframes back share
/// more with the query than the map's other places do (the same landscape, the same building),
/// so a candidate among them must stand out of their own tail, not only the map's.
class PassedPlaceScores {
 public:
  static constexpr size_t kQueries = 200;     ///< Queries pooled.
  static constexpr size_t kMinSamples = 200;  ///< Fewer scores: nothing to calibrate on yet.

  /// One query's scores at the passed places.
  void add(std::vector<double> scores);
  void clear() { queries_.clear(); }
  size_t samples() const;
  /// Invalid while fewer than kMinSamples scores are pooled.
  ScoreTail tail() const;

 private:
  std::deque<std::vector<double>> queries_;
};

}  // namespace landmark_loop_closure
