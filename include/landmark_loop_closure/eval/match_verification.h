// Single-image matches checked as the node checks a loop candidate: ORB's geometric check where
// the camera's intrinsics are known, then the appearance check on the two keyframes' thumbnails.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/geometry/camera_intrinsics.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"

namespace landmark_loop_closure {
namespace eval {

/// The node's checks of a loop candidate (verification/ and advanced/verification/appearance/).
struct MatchChecks {
  AppearanceCheckOptions appearance;
  /// ORB's check runs first where `geometry.enabled` and `intrinsics` are valid (of the camera,
  /// scaled to the images as loaded): a place it confirms is confirmed, otherwise the appearance
  /// check decides (where `appearance.enabled`), and without cells to compare the match is
  /// refused, as the node refuses it.
  VerificationOptions geometry;
  CameraIntrinsics intrinsics;

  bool runsGeometry() const { return geometry.enabled && intrinsics.valid(); }
};

struct MatchVerificationSummary {
  size_t checked = 0;                ///< Best matches a check ran on.
  size_t refused = 0;                ///< Of those, refused.
  size_t refused_correct = 0;        ///< Refused although the ground truth says same place.
  size_t confirmed_correct = 0;      ///< Confirmed and right: what the node could publish.
  size_t confirmed_wrong = 0;        ///< Confirmed although wrong: false loops the checks let by.
  size_t confirmed_by_geometry = 0;  ///< Of the confirmed, by ORB (the rest by appearance).
  size_t unverifiable = 0;           ///< No check could run (no ORB, no cells): left as is.
};

/// Runs `checks` on each outcome's best match as the node runs them on a loop candidate: ORB on
/// the images as loaded (GeometricVerifier::extractKeyframe), the appearance check on the
/// thumbnails the node stores (makeThumbnail); records the inliers of each. The node publishes no
/// loop the checks refuse, so a refused match is ranked below every other: all refused scores
/// are shifted by one amount that puts the highest of them under the lowest unrefused score
/// (their order among themselves kept). Matches stay matches: recall@1 does not change. A match
/// no check can run on is left as it is, as the node publishes such a loop unverified.
/// `query_image(i)` / `database_image(j)` load the images (colour or grey; empty: no check).
MatchVerificationSummary verifyMatches(std::vector<QueryOutcome>* outcomes,
                                       const std::function<cv::Mat(size_t)>& query_image,
                                       const std::function<cv::Mat(size_t)>& database_image,
                                       const DescriptorExtractor& extractor,
                                       const MatchChecks& checks);

}  // namespace eval
}  // namespace landmark_loop_closure
