// Single-image matches checked as the node checks a loop candidate without intrinsics: the
// appearance check on the two keyframes' thumbnails.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/metrics.h"

namespace landmark_loop_closure {
namespace eval {

struct MatchVerificationSummary {
  size_t checked = 0;            ///< Best matches the check ran on.
  size_t refused = 0;            ///< Of those, refused.
  size_t refused_correct = 0;    ///< Refused although the ground truth says same place.
  size_t confirmed_correct = 0;  ///< Confirmed and right: what the node could publish.
  size_t confirmed_wrong = 0;    ///< Confirmed although wrong: false loops the check lets by.
  size_t unverifiable = 0;       ///< No feature-map cells (e.g. the HOG-only path): left as is.
};

/// Runs `options`' appearance check on each outcome's best match, both images made into the
/// thumbnail the node stores (makeThumbnail), and records the inliers. The node publishes no loop
/// the check refuses, so a refused match is ranked below every other: all refused scores are
/// shifted by one amount that puts the highest of them under the lowest unrefused score (their
/// order among themselves kept). Matches stay matches: recall@1 does not change. A match whose
/// images give no cells is left as it is, as the node publishes such a loop unverified.
/// `query_image(i)` / `database_image(j)` load the images (colour or grey; empty: unverifiable).
MatchVerificationSummary verifyMatches(std::vector<QueryOutcome>* outcomes,
                                       const std::function<cv::Mat(size_t)>& query_image,
                                       const std::function<cv::Mat(size_t)>& database_image,
                                       const DescriptorExtractor& extractor,
                                       const AppearanceCheckOptions& options);

}  // namespace eval
}  // namespace landmark_loop_closure
