// LoopDetector's verification stage (checkPlace, shared with loops between robots).
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/core/place_check.h"

namespace landmark_loop_closure {

CellFeatures LoopDetector::thumbnailCells(const KeyframeRecord& keyframe) const {
  const cv::Mat thumbnail = decodeThumbnail(keyframe.thumbnail);
  if (thumbnail.empty()) return {};
  return cellFeatures(describer_.extractor().appearanceMaps(thumbnail));
}

bool LoopDetector::verify(const KeyframeRecord& query, const KeyframeRecord& match,
                          const CameraIntrinsics& intrinsics, CandidateReport* report,
                          AcceptedLoop* loop, std::optional<CellFeatures>* query_cells) {
  PlaceCheck check = checkPlace(
      verifier_, {options_.verification, options_.appearance, options_.metric_pose},
      query.local_features, match.local_features, intrinsics, query_cells,
      [&] { return thumbnailCells(query); }, [&] { return thumbnailCells(match); },
      CandidateCertainty{report->false_alarms, report->continues_loop});
  report->inliers = check.inliers;
  if (!check.detail.empty()) report->detail = check.detail;
  if (!check.accepted) {
    report->verdict = CandidateVerdict::kGeometryRejected;
    return false;
  }
  loop->verification = std::move(check.verification);
  loop->appearance = check.appearance;
  loop->metric_pose = std::move(check.metric_pose);
  loop->relative_pose = check.relative_pose;
  return true;
}

}  // namespace landmark_loop_closure
