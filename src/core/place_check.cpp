// The verification stage shared by the detector's loops and loops between robots: ORB with the
// camera's intrinsics, a metric pose from keypoint depths, and where ORB cannot confirm the
// place (no camera_info, day against night) the appearance check.
#include "landmark_loop_closure/core/place_check.h"

namespace landmark_loop_closure {

PlaceCheck checkPlace(const GeometricVerifier& verifier, const PlaceCheckSettings& settings,
                      const LocalFeatures& query, const LocalFeatures& match,
                      const CameraIntrinsics& intrinsics, std::optional<CellFeatures>* query_cells,
                      const CellsOfKeyframe& query_cells_of, const CellsOfKeyframe& match_cells_of,
                      const CandidateCertainty& certainty) {
  PlaceCheck outcome;
  if (!settings.verification.enabled) {
    outcome.accepted = true;
    return outcome;
  }
  VerificationResult check = verifier.verify(query, match, intrinsics);
  outcome.inliers = check.inliers;
  if (check.placeConfirmed()) {
    // The place is confirmed; depths of the match's keypoints can still give a metric pose, even
    // where two views left the pose ambiguous or without parallax.
    if (!match.points3d.empty()) {
      MetricPoseResult metric = estimateMetricPose(
          query, match, ratioTestMatches(query, match, settings.verification.ratio_test),
          intrinsics, settings.verification, settings.metric_pose);
      if (metric.found) {
        outcome.relative_pose = metric.pose;
      } else {
        outcome.detail = "no metric pose: " + metric.failure;
      }
      outcome.metric_pose = std::move(metric);
    }
    if (!outcome.relative_pose && check.accepted() &&
        settings.verification.publish_scale_free_pose) {
      outcome.relative_pose = withUnknownScale(check.pose);
    }
    outcome.verification = std::move(check);
    outcome.accepted = outcome.place_confirmed = true;
    return outcome;
  }
  // ORB cannot confirm the place: the network's cells, which survive a change of light, decide
  // when both keyframes have a thumbnail to compare.
  if (settings.appearance.enabled &&
      !(settings.verification.required && check.verdict == VerificationVerdict::kNoIntrinsics)) {
    if (!*query_cells) *query_cells = query_cells_of();
    const CellFeatures match_cells = (*query_cells)->empty() ? CellFeatures{} : match_cells_of();
    if (!match_cells.empty()) {
      const AppearanceCheckResult appearance =
          checkAppearance(**query_cells, match_cells, settings.appearance, certainty);
      outcome.inliers = appearance.inliers;
      outcome.detail = std::string(toString(check.verdict)) + "; " + appearance.describe();
      if (appearance.confirmed) {
        outcome.appearance = appearance;
        outcome.accepted = outcome.place_confirmed = true;
      }
      return outcome;
    }
  }
  if (check.verdict == VerificationVerdict::kNoIntrinsics && !settings.verification.required) {
    outcome.accepted = true;  // Unverified: published without a relative pose.
    return outcome;
  }
  outcome.detail = toString(check.verdict);
  return outcome;
}

}  // namespace landmark_loop_closure
