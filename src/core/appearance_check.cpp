#include "landmark_loop_closure/core/appearance_check.h"

#include <algorithm>
#include <sstream>

#include <opencv2/calib3d.hpp>

namespace landmark_loop_closure {

const ParameterTable<AppearanceCheckOptions>& AppearanceCheckOptions::parameters() {
  using O = AppearanceCheckOptions;
  static const auto table =
      ParameterTable<O>("advanced/verification/appearance/",
                        "a loop the ORB check cannot confirm (no camera_info, or day against "
                        "night) is confirmed or refused by the backbone's feature-map cells.")
          .flag("enabled", &O::enabled,
                "check such loops by the network's cells (backbone descriptor and thumbnails "
                "needed); off: they are published unverified without camera_info and refused "
                "when the ORB check refused them.")
          .integer("min_inliers", &O::min_inliers, between(3, 10000),
                   "cells (of 144 at the default input) that are mutual nearest neighbours and "
                   "fit one affine map of positions. Chosen on Gardens Point's first half: the "
                   "same place by day and by night has 25 / 38 (10th percentile / median), the "
                   "most alike wrong places 21-31 at the 90th percentile (bench/README.md).")
          .integer("sure_min_inliers", &O::sure_min_inliers, between(3, 10000),
                   "cells a candidate needs when the calibrated decision is sure of it (see "
                   "sure_false_alarms): a change of viewpoint moves cells out of one affine map "
                   "(the same place seen from the other side of a path keeps 12-27 of them), and "
                   "a look-alike place is refused by the decision before it gets here.")
          .number("sure_false_alarms", &O::sure_false_alarms, between(0, 1),
                  "a candidate with at most this many wrong places expected to score as high "
                  "(advanced/acceptance/max_false_alarms' estimate; between robots, "
                  "advanced/fleet/max_false_alarms') needs sure_min_inliers cells, others "
                  "min_inliers. 0 = off. 20 and 1e-4 were chosen on the first halves of Gardens "
                  "Point and Nordland, a step inside the values with no wrong loop (16-24 cells, "
                  "1e-5 to 1e-3; any candidate at 20 or 24 cells: 3-5 wrong loops on Nordland); "
                  "reported on the second halves (bench/README.md).")
          .integer("continuing_min_inliers", &O::continuing_min_inliers, between(0, 10000),
                   "cells a candidate needs when it continues the last published loop "
                   "(advanced/acceptance/continue_across) and keeps up with it (its match not "
                   "behind that loop's, nor on it a second keyframe in a row: a stretch falling "
                   "behind names the place's neighbour): the place was confirmed a few keyframes "
                   "ago, and a change of viewpoint moves cells out of one affine map keyframe "
                   "after keyframe. 0 = as any other. 16 was chosen on the first halves of Gardens "
                   "Point and Nordland: "
                   "6-18 published no wrong loop there, 16 is the largest that kept 12's loops "
                   "(bench/history.md).")
          .number("ransac_threshold_cells", &O::ransac_threshold_cells,
                  openBetween(0, 100, true, false), "affine RANSAC inlier distance in cells.")
          .evaluationOnly();
  return table;
}

std::string AppearanceCheckOptions::validate() const { return parameters().check(*this); }

CellFeatures cellFeatures(const FeatureMaps& maps) {
  CellFeatures cells;
  if (maps.empty()) return cells;
  const int count = maps.width * maps.height;
  cells.features.create(count, maps.channels, CV_32F);
  for (int c = 0; c < maps.channels; ++c) {
    const float* channel = maps.channel(c);
    double mean = 0.0;
    for (int i = 0; i < count; ++i) mean += channel[i];
    mean /= count;
    for (int i = 0; i < count; ++i) {
      cells.features.at<float>(i, c) = static_cast<float>(channel[i] - mean);
    }
  }
  for (int i = 0; i < count; ++i) {
    cv::Mat row = cells.features.row(i);
    const double norm = cv::norm(row);
    if (norm > 0.0) row /= norm;
    cells.centres.emplace_back(static_cast<float>(i % maps.width),
                               static_cast<float>(i / maps.width));
  }
  return cells;
}

std::string AppearanceCheckResult::describe() const {
  std::ostringstream text;
  text << "appearance: " << inliers << " of " << mutual_matches << " cells agree";
  if (required > 0) text << " (" << required << " needed)";
  return text.str();
}

int requiredCells(const AppearanceCheckOptions& options, const CandidateCertainty& certainty) {
  int required = options.min_inliers;
  const bool sure = options.sure_false_alarms > 0.0 && certainty.false_alarms >= 0.0 &&
                    certainty.false_alarms <= options.sure_false_alarms;
  if (sure) required = std::min(required, options.sure_min_inliers);
  if (certainty.continues_loop && options.continuing_min_inliers > 0) {
    required = std::min(required, options.continuing_min_inliers);
  }
  return required;
}

AppearanceCheckResult checkAppearance(const CellFeatures& query, const CellFeatures& match,
                                      const AppearanceCheckOptions& options,
                                      const CandidateCertainty& certainty) {
  AppearanceCheckResult result;
  result.required = requiredCells(options, certainty);
  if (query.empty() || match.empty() || query.features.cols != match.features.cols ||
      query.centres.size() != match.centres.size()) {
    return result;
  }
  std::vector<cv::Point2f> from, to;
  for (const LandmarkMatch& pair : matchLandmarks(query.features, match.features)) {
    from.push_back(query.centres[pair.a]);
    to.push_back(match.centres[pair.b]);
  }
  result.mutual_matches = static_cast<int>(from.size());
  if (from.size() >= 3) {
    std::vector<uchar> inlier_mask;
    const cv::Mat affine = cv::estimateAffine2D(from, to, inlier_mask, cv::RANSAC,
                                                options.ransac_threshold_cells, 2000, 0.995, 10);
    if (!affine.empty()) result.inliers = cv::countNonZero(inlier_mask);
  }
  result.confirmed = result.inliers >= result.required;
  return result;
}

}  // namespace landmark_loop_closure
