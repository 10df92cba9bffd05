// LoopDetector's verification stage: the ORB check with the camera's intrinsics, and where it
// cannot confirm the place (no camera_info, day against night) the appearance check.
#include "landmark_loop_closure/core/loop_detector.h"

namespace landmark_loop_closure {

CellFeatures LoopDetector::thumbnailCells(const KeyframeRecord& keyframe) const {
  const cv::Mat thumbnail = decodeThumbnail(keyframe.thumbnail);
  if (thumbnail.empty()) return {};
  return cellFeatures(extractor_->appearanceMaps(thumbnail));
}

bool LoopDetector::verify(const KeyframeRecord& query, const KeyframeRecord& match,
                          const CameraIntrinsics& intrinsics, CandidateReport* report,
                          AcceptedLoop* loop, std::optional<CellFeatures>* query_cells) {
  if (!options_.verification.enabled) return true;
  const LocalFeatures& features = query.local_features;
  VerificationResult check = verifier_.verify(features, match.local_features, intrinsics);
  report->inliers = check.inliers;
  if (check.placeConfirmed()) {
    // The place is confirmed; depths of the match's keypoints can still give a metric pose, even
    // where two views left the pose ambiguous or without parallax.
    if (!match.local_features.points3d.empty()) {
      MetricPoseResult metric = estimateMetricPose(
          features, match.local_features,
          ratioTestMatches(features, match.local_features, options_.verification.ratio_test),
          intrinsics, options_.verification, options_.metric_pose);
      if (metric.found) {
        loop->relative_pose = metric.pose;
      } else {
        report->detail = "no metric pose: " + metric.failure;
      }
      loop->metric_pose = std::move(metric);
    }
    if (!loop->relative_pose && check.accepted() && options_.verification.publish_scale_free_pose) {
      loop->relative_pose = withUnknownScale(check.pose);
    }
    loop->verification = std::move(check);
    return true;
  }
  // ORB cannot confirm the place: the network's cells, which survive a change of light, decide
  // when both keyframes have a thumbnail to compare.
  if (options_.appearance.enabled &&
      !(options_.verification.required && check.verdict == VerificationVerdict::kNoIntrinsics)) {
    if (!*query_cells) *query_cells = thumbnailCells(query);
    const CellFeatures match_cells =
        (*query_cells)->empty() ? CellFeatures{} : thumbnailCells(match);
    if (!match_cells.empty()) {
      const AppearanceCheckResult appearance =
          checkAppearance(**query_cells, match_cells, options_.appearance);
      report->inliers = appearance.inliers;
      report->detail = std::string(toString(check.verdict)) + "; " + appearance.describe();
      if (appearance.confirmed) {
        loop->appearance = appearance;
        return true;
      }
      report->verdict = CandidateVerdict::kGeometryRejected;
      return false;
    }
  }
  if (check.verdict == VerificationVerdict::kNoIntrinsics && !options_.verification.required) {
    return true;  // Unverified: published without a relative pose.
  }
  report->verdict = CandidateVerdict::kGeometryRejected;
  report->detail = toString(check.verdict);
  return false;
}

}  // namespace landmark_loop_closure
