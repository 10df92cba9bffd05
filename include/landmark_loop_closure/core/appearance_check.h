#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/descriptors/landmarks.h"

namespace landmark_loop_closure {

/// A check of a loop candidate on features that survive a change of light: the cells of the
/// backbone's feature map (16x9 at the default input), matched as mutual nearest neighbours and
/// counted when one affine map of cell positions explains them. The same place seen by day and by
/// night keeps its layout; two dark places that merely look alike do not. It runs where the
/// ORB check cannot confirm a place (no intrinsics, or too few ORB matches across day and night)
/// and gives no relative pose.
struct AppearanceCheckOptions {
  bool enabled = true;
  /// Cells that one affine map must explain; fewer: the candidate is refused.
  int min_inliers = 28;
  /// A candidate the calibrated decision is surer of (at most sure_false_alarms wrong places
  /// expected to score as high) needs only sure_min_inliers: a change of viewpoint moves cells
  /// out of one affine map, a look-alike place fails the decision first.
  int sure_min_inliers = 20;
  double sure_false_alarms = 1e-4;  ///< 0 = every candidate needs min_inliers.
  /// A candidate that continues the loop the keyframe before published and keeps up with it
  /// (CandidateReport::continues_loop: the place was confirmed one keyframe ago) needs only
  /// continuing_min_inliers: 0 = as any other.
  int continuing_min_inliers = 16;
  double ransac_threshold_cells = 1.5;  ///< Affine RANSAC inlier distance, in feature-map cells.

  /// Keys under advanced/verification/appearance/, documented in config/default.yaml.
  static const ParameterTable<AppearanceCheckOptions>& parameters();
  std::string validate() const;
};

/// One image's feature-map cells: one row per cell (CV_32F, each channel's mean over the image
/// removed, rows L2-normalised) and its centre in cell units.
struct CellFeatures {
  cv::Mat features;
  std::vector<cv::Point2f> centres;
  bool empty() const { return features.empty(); }
};

CellFeatures cellFeatures(const FeatureMaps& maps);

struct AppearanceCheckResult {
  int mutual_matches = 0;        ///< Cells that are each other's nearest neighbour.
  int inliers = 0;               ///< Of those, explained by the best affine map.
  int required = 0;              ///< Cells it needed (requiredCells).
  bool confirmed = false;        ///< inliers >= required.
  std::string describe() const;  ///< "appearance: 31 of 52 cells agree (28 needed)".
};

/// What the decision knows of a candidate before it is checked.
struct CandidateCertainty {
  /// The calibrated decision's expected wrong places as high; -1 when it was not tested.
  double false_alarms = -1.0;
  /// It continues the loop the keyframe before published.
  bool continues_loop = false;
};

/// The cells a candidate needs: the fewest of min_inliers, sure_min_inliers when its false alarms
/// are at most sure_false_alarms, and continuing_min_inliers when it continues a loop (and that is
/// set).
int requiredCells(const AppearanceCheckOptions& options, const CandidateCertainty& certainty);

/// Compares two images' cells; images of other cell grids or channel counts are not confirmed.
AppearanceCheckResult checkAppearance(const CellFeatures& query, const CellFeatures& match,
                                      const AppearanceCheckOptions& options,
                                      const CandidateCertainty& certainty = {});

}  // namespace landmark_loop_closure
