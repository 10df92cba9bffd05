#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// What the match view shows: a keyframe (left) and the keyframe it matched (right).
struct MatchView {
  enum class Verdict {
    kAccepted,   ///< A published loop: the verdict band is green.
    kCandidate,  ///< Not (yet) a loop, e.g. awaiting consistency: orange.
    kRejected    ///< Refused (outscored, odometry, geometry): grey.
  };
  cv::Mat query;  ///< Grey or colour; empty: a dark placeholder.
  cv::Mat match;
  Verdict verdict = Verdict::kCandidate;
  std::string headline;  ///< The verdict and ids, in large letters on the verdict's colour.
  std::string details;   ///< Score, inliers, reason: one smaller line under it.
  /// Matched landmark boxes (query box, match box), each in its own image's pixels, strongest
  /// first; only the first kMaxLandmarkPairs are drawn, each pair in a colour of its own.
  std::vector<std::pair<cv::Rect2f, cv::Rect2f>> landmark_pairs;
  /// Geometric inliers (query point, match point) in each image's pixels: green dots joined.
  std::vector<std::pair<cv::Point2f, cv::Point2f>> inliers;

  static constexpr size_t kMaxLandmarkPairs = 5;
};

/// The view as one picture: a band with the headline (white on the verdict's colour) and the
/// details line on top, then both images side by side at `height` pixels. Sized to be read in
/// rviz's image panel at its default size.
cv::Mat renderMatchImage(const MatchView& view, int height = 240);

}  // namespace landmark_loop_closure
