#pragma once

#include <functional>
#include <optional>
#include <string>

#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/geometry/camera_intrinsics.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/metric_pose.h"

namespace landmark_loop_closure {

/// What the verification stage said of a candidate pair: the detector's own loops and loops
/// into another robot's map (whose keypoints and thumbnail were fetched) go through it alike.
struct PlaceCheck {
  /// The loop may be accepted: the place was confirmed, or could not be checked and need not be
  /// (verification off; no intrinsics while advanced/verification/required is false).
  bool accepted = false;
  /// The ORB check or the appearance check confirmed the place (a loop between robots, with no
  /// odometry between them, needs this).
  bool place_confirmed = false;
  int inliers = 0;     ///< ORB inliers, or the appearance check's cells.
  std::string detail;  ///< Why refused, or what was missing (no metric pose).
  std::optional<VerificationResult> verification;
  std::optional<AppearanceCheckResult> appearance;
  std::optional<MetricPoseResult> metric_pose;
  /// The metric pose when found, else the verified scale-free one when
  /// verification.publish_scale_free_pose is set.
  std::optional<RelativePose> relative_pose;
};

/// The settings the check reads (the detector's, by reference).
struct PlaceCheckSettings {
  const VerificationOptions& verification;
  const AppearanceCheckOptions& appearance;
  const MetricPoseOptions& metric_pose;
};

/// The appearance check's cells of one keyframe's thumbnail (empty when it has none).
using CellsOfKeyframe = std::function<CellFeatures()>;

/// The ORB check of `query` against `match` with `intrinsics`; where it confirms the place, a
/// metric pose from the match's keypoint depths when it has them. Where ORB cannot confirm the
/// place, the appearance check of the two thumbnails: `query_cells` holds the query's once
/// computed (several candidates share it), `match_cells` computes the match's on demand;
/// `certainty` (the calibrated decision's estimate, whether it continues a loop) sets the cells
/// it needs (requiredCells).
PlaceCheck checkPlace(const GeometricVerifier& verifier, const PlaceCheckSettings& settings,
                      const LocalFeatures& query, const LocalFeatures& match,
                      const CameraIntrinsics& intrinsics, std::optional<CellFeatures>* query_cells,
                      const CellsOfKeyframe& query_cells_of, const CellsOfKeyframe& match_cells_of,
                      const CandidateCertainty& certainty = {});

}  // namespace landmark_loop_closure
