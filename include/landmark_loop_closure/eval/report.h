#pragma once

#include <functional>
#include <string>
#include <vector>

#include "landmark_loop_closure/eval/evaluator.h"

namespace landmark_loop_closure {
namespace eval {

struct RunDescription {
  std::string dataset;       ///< Free text, e.g. "nordland summer vs winter".
  std::string mode;          ///< "traversal" or "sequence".
  std::string ground_truth;  ///< Where the ground truth came from.
  size_t database_images = 0;
  size_t query_images = 0;
  std::vector<Pose> trajectory;  ///< Sequence mode with poses: written to trajectory.csv.
};

/// Writes into `folder` (created if needed): results.json (every configuration's measures),
/// pr_<name>.csv (the curve), matches_<name>.csv (every query's best match, whether it is right,
/// and whether it is accepted at the 100 %-precision threshold), similarity_<name>.png and
/// ground_truth.png, and trajectory.csv when the run has poses. Returns the path of results.json.
std::string writeReport(const std::string& folder, const RunDescription& run,
                        const std::vector<Evaluation>& evaluations, const GroundTruth& truth,
                        int matrix_size);

/// The `pairs` best-scoring query/match pairs side by side with their indices and score, a grid
/// of them in one PNG at `path`, to look at. `judge`: frame each pair green (right) or red
/// (wrong); without, grey. `load_query(i)` / `load_database(j)` return the images (BGR or grey).
void writeContactSheet(const std::string& path, const std::vector<QueryOutcome>& outcomes,
                       const std::function<cv::Mat(size_t)>& load_query,
                       const std::function<cv::Mat(size_t)>& load_database, bool judge, int pairs);

/// `text` as a JSON string literal, quotes and backslashes escaped.
std::string jsonString(const std::string& text);

/// Peak resident memory of this process in bytes (VmHWM), 0 when unknown.
size_t peakResidentBytes();

}  // namespace eval
}  // namespace landmark_loop_closure
