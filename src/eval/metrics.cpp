#include "landmark_loop_closure/eval/metrics.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {
namespace eval {

Metrics computeMetrics(const std::vector<QueryOutcome>& outcomes) {
  Metrics metrics;
  metrics.queries = outcomes.size();
  std::vector<const QueryOutcome*> ranked;
  size_t correct_at_any_score = 0;
  for (const QueryOutcome& outcome : outcomes) {
    metrics.queries_with_truth += outcome.has_truth ? 1 : 0;
    correct_at_any_score += outcome.correct ? 1 : 0;
    if (outcome.match >= 0) {
      ranked.push_back(&outcome);
    } else if (outcome.has_truth) {
      ++metrics.unmatched_with_truth;
    }
  }
  if (metrics.queries_with_truth == 0) return metrics;
  const double positives = static_cast<double>(metrics.queries_with_truth);
  metrics.recall_at_1 = correct_at_any_score / positives;

  std::stable_sort(ranked.begin(), ranked.end(), [](const QueryOutcome* a, const QueryOutcome* b) {
    return a->score > b->score;
  });
  size_t true_positives = 0;
  size_t false_positives = 0;
  double previous_recall = 0.0;
  double previous_precision = 1.0;
  for (size_t i = 0; i < ranked.size();) {
    // Equal scores pass or fail a threshold together.
    const double score = ranked[i]->score;
    size_t group_true = 0;
    size_t group_size = 0;
    for (; i < ranked.size() && ranked[i]->score == score; ++i, ++group_size) {
      group_true += ranked[i]->correct ? 1 : 0;
    }
    // Average precision: each true positive of the group at the group's precision.
    true_positives += group_true;
    false_positives += group_size - group_true;
    const double precision =
        static_cast<double>(true_positives) / static_cast<double>(true_positives + false_positives);
    const double recall = true_positives / positives;
    metrics.average_precision += precision * group_true / positives;
    metrics.auc += 0.5 * (precision + previous_precision) * (recall - previous_recall);
    if (false_positives == 0) {
      metrics.recall_at_100_precision = recall;
      metrics.threshold_at_100_precision = score;
    }
    metrics.curve.push_back({score, precision, recall});
    previous_recall = recall;
    previous_precision = precision;
    if (correct_at_any_score > 0) {
      const double vpr_recall = true_positives / static_cast<double>(correct_at_any_score);
      // sklearn's precision_recall_curve, which VPR-Bench calls, ends its curve at recall 0,
      // precision 1: the first trapezoid starts there.
      const double last_recall =
          metrics.vprbench.curve.empty() ? 0.0 : metrics.vprbench.curve.back().recall;
      const double last_precision =
          metrics.vprbench.curve.empty() ? 1.0 : metrics.vprbench.curve.back().precision;
      metrics.vprbench.auc += 0.5 * (precision + last_precision) * (vpr_recall - last_recall);
      if (false_positives == 0) metrics.vprbench.recall_at_100_precision = vpr_recall;
      metrics.vprbench.curve.push_back({score, precision, vpr_recall});
    }
  }
  metrics.vprbench.correct_matches = correct_at_any_score;
  return metrics;
}

Percentiles percentiles(std::vector<double> values) {
  Percentiles result;
  if (values.empty()) return result;
  std::sort(values.begin(), values.end());
  const auto rank = [&values](double q) {
    const size_t index = static_cast<size_t>(std::ceil(q * values.size())) - 1;
    return values[std::min(index, values.size() - 1)];
  };
  result.median = rank(0.5);
  result.p99 = rank(0.99);
  return result;
}

}  // namespace eval
}  // namespace landmark_loop_closure
