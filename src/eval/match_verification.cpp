#include "landmark_loop_closure/eval/match_verification.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

CellFeatures thumbnailCells(const cv::Mat& image, const DescriptorExtractor& extractor) {
  if (image.empty()) return {};
  return cellFeatures(extractor.appearanceMaps(decodeThumbnail(makeThumbnail(image))));
}

}  // namespace

MatchVerificationSummary verifyMatches(std::vector<QueryOutcome>* outcomes,
                                       const std::function<cv::Mat(size_t)>& query_image,
                                       const std::function<cv::Mat(size_t)>& database_image,
                                       const DescriptorExtractor& extractor,
                                       const MatchChecks& checks) {
  MatchVerificationSummary summary;
  const GeometricVerifier verifier(checks.geometry);
  // Features are made again for a database image matched twice: as the node makes them, and
  // without holding them per matched image over a long sequence.
  for (QueryOutcome& outcome : *outcomes) {
    outcome.geometry_inliers = -1;
    outcome.appearance_inliers = -1;
    outcome.refused = false;
    if (outcome.match < 0) continue;
    const cv::Mat query = query_image(outcome.query);
    const cv::Mat match = database_image(static_cast<size_t>(outcome.match));
    bool confirmed = false;
    bool checked = false;
    if (checks.runsGeometry() && !query.empty() && !match.empty()) {
      const VerificationResult geometry =
          verifier.verify(verifier.extractKeyframe(query, checks.intrinsics),
                          verifier.extractKeyframe(match, checks.intrinsics), checks.intrinsics);
      checked = true;
      outcome.geometry_inliers = geometry.inliers;
      confirmed = geometry.placeConfirmed();
      summary.confirmed_by_geometry += confirmed ? 1 : 0;
    }
    if (!confirmed && checks.appearance.enabled) {
      const CellFeatures query_cells = thumbnailCells(query, extractor);
      const CellFeatures match_cells =
          query_cells.empty() ? CellFeatures{} : thumbnailCells(match, extractor);
      if (!query_cells.empty() && !match_cells.empty()) {
        const AppearanceCheckResult check =
            checkAppearance(query_cells, match_cells, checks.appearance);
        checked = true;
        outcome.appearance_inliers = check.inliers;
        confirmed = check.confirmed;
      }
    }
    if (!checked) {
      ++summary.unverifiable;
      continue;
    }
    ++summary.checked;
    if (confirmed) {
      ++(outcome.correct ? summary.confirmed_correct : summary.confirmed_wrong);
    } else {
      outcome.refused = true;
      ++summary.refused;
      summary.refused_correct += outcome.correct ? 1 : 0;
    }
  }
  double lowest_kept = std::numeric_limits<double>::infinity();
  double highest_refused = -std::numeric_limits<double>::infinity();
  for (const QueryOutcome& outcome : *outcomes) {
    if (outcome.match < 0) continue;
    if (outcome.refused) {
      highest_refused = std::max(highest_refused, outcome.score);
    } else {
      lowest_kept = std::min(lowest_kept, outcome.score);
    }
  }
  if (summary.refused > 0 && std::isfinite(lowest_kept) && highest_refused >= lowest_kept) {
    const double shift = highest_refused - lowest_kept + 1.0;
    for (QueryOutcome& outcome : *outcomes) {
      if (outcome.refused) outcome.score -= shift;
    }
  }
  return summary;
}

}  // namespace eval
}  // namespace landmark_loop_closure
