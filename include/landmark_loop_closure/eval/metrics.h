#pragma once

#include <cstddef>
#include <vector>

namespace landmark_loop_closure {
namespace eval {

/// The best match found for one query image.
struct QueryOutcome {
  size_t query = 0;
  long match = -1;         ///< Index of the best database image; -1 when nothing was searched.
  double score = 0.0;      ///< Its similarity; the acceptance threshold is swept over these.
  bool correct = false;    ///< The ground truth says query and match are the same place.
  bool has_truth = false;  ///< The ground truth has at least one place for this query.
  /// With verifyMatches: ORB inliers of the geometric check and cells the appearance check found
  /// in one layout (-1: not run), and whether the checks refused the match (then `score` is
  /// shifted below every unrefused match's).
  int geometry_inliers = -1;
  int appearance_inliers = -1;
  bool refused = false;
};

struct PrPoint {
  double threshold = 0.0;
  double precision = 1.0;
  double recall = 0.0;
};

/// The literature's measures: a query is a positive when its best score reaches the threshold;
/// a positive is true when its match is right. Recall = true positives / queries that have a
/// ground-truth place.
struct Metrics {
  std::vector<PrPoint> curve;            ///< One point per distinct score, high to low.
  double auc = 0.0;                      ///< Area under precision(recall), trapezoids from (0, 1).
  double recall_at_100_precision = 0.0;  ///< Highest recall with no false positive.
  double threshold_at_100_precision = 0.0;
  double average_precision = 0.0;
  double recall_at_1 = 0.0;  ///< Correct best matches / queries with a place.
  size_t queries = 0;
  size_t queries_with_truth = 0;
  /// Queries with a place that matched nothing (a vector of zeros): misses in every recall,
  /// never ranked.
  size_t unmatched_with_truth = 0;

  /// VPR-Bench's convention (Zaffar et al., IJCV 2021), for rows beside its tables: the same
  /// best matches and scores, but recall = true positives / queries whose best match is right
  /// (so it always reaches 1 at the lowest threshold), and the AUC integrates the curve with
  /// trapezoids from the point (recall 0, precision 1) that sklearn's precision_recall_curve
  /// appends, as VPR-Bench's auc(recall, precision) over that curve does.
  struct VprBench {
    std::vector<PrPoint> curve;
    double auc = 0.0;
    double recall_at_100_precision = 0.0;
    size_t correct_matches = 0;  ///< The recall's denominator.
  } vprbench;
};

Metrics computeMetrics(const std::vector<QueryOutcome>& outcomes);

/// Median and 99th percentile (nearest rank) of a sample; 0 for an empty one.
struct Percentiles {
  double median = 0.0;
  double p99 = 0.0;
};
Percentiles percentiles(std::vector<double> values);

}  // namespace eval
}  // namespace landmark_loop_closure
