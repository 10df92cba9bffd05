#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/geometry/camera_intrinsics.h"

namespace landmark_loop_closure {

/// Keypoints of one keyframe, kept with it for verification: ORB, 32 bytes each.
struct LocalFeatures {
  std::vector<cv::Point2f> points;  ///< Pixels of the image they were found in.
  cv::Mat descriptors;              ///< CV_8U, one 32-byte row per point.
  cv::Size image_size;
  /// Each keypoint's position in this keyframe's camera frame (metres, optical axes), NaN where
  /// unknown; empty when no depth source was available.
  std::vector<cv::Point3f> points3d;
  /// Standard deviation of each point's depth along its ray (metres), beside points3d.
  std::vector<float> depth_sd;

  bool empty() const { return points.empty(); }
  size_t bytes() const;
};

struct VerificationOptions {
  bool enabled = true;    ///< Check every loop before accepting it.
  bool required = false;  ///< Refuse loops that cannot be checked (no camera_info).
  /// Publish scale-free (monocular) relative poses as usable by a pose graph. Off: they are
  /// checked and drawn, but has_relative_pose stays false (see the README for their accuracy).
  bool publish_scale_free_pose = false;
  int max_image_width = 640;  ///< Keypoints are found on the image shrunk to this width.
  int max_features = 400;     ///< ORB keypoints kept per keyframe.
  /// ORB pyramid levels (scale 1.2). One: keypoints from coarser levels are placed up to a
  /// pixel off, which skews the pose; revisits are seen at about the same scale.
  int orb_levels = 1;
  double ratio_test = 0.8;           ///< Lowe's ratio: best / second-best Hamming distance.
  double ransac_threshold_px = 1.5;  ///< Essential-matrix RANSAC inlier threshold.
  int min_inliers = 30;              ///< Fewer inliers: the loop is refused.
  double min_spread = 0.25;          ///< Share of a 4x4 grid over the query image holding inliers.
  double min_parallax_deg = 1.0;     ///< Median ray angle after rotation; below: no translation.
  /// Translation directions (over the half sphere) at which the best rotation is fitted, to find
  /// every direction the matches cannot rule out.
  int ambiguity_directions = 300;
  /// Keypoint position noise assumed at least (pixels): ORB keypoints sit on whole pixels.
  double keypoint_sigma_px = 0.5;
  double max_rotation_sd_deg = 1.0;   ///< Larger rotation uncertainty: the loop is refused.
  double max_direction_sd_deg = 5.0;  ///< Same for the translation direction.

  /// Keys under verification/, documented in config/default.yaml.
  static const ParameterTable<VerificationOptions>& parameters();
  std::string validate() const;
};

enum class VerificationVerdict {
  kAccepted,
  kNoIntrinsics,      ///< No camera_info yet, or invalid.
  kTooFewFeatures,    ///< One image has fewer keypoints than min_inliers (no texture?).
  kTooFewMatches,     ///< Fewer ratio-test matches than min_inliers.
  kTooFewInliers,     ///< The essential matrix explains fewer than min_inliers matches.
  kInliersClustered,  ///< Inliers cover less than min_spread of the image.
  kNoParallax,        ///< Pure rotation (or a distant scene): the translation is undefined.
  kAmbiguous,         ///< The matches do not pin the pose down (resamples disagree).
};

const char* toString(VerificationVerdict verdict);

/// T_query_match: the match camera's pose in the query camera's frame (optical axes: x right,
/// y down, z forward), so that X_query = rotation * X_match + translation.
struct RelativePose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  bool metric = false;  ///< false: translation is a unit direction (monocular, scale-free).
  /// Row-major order x, y, z, rotation about x, y, z (rad), from the inlier residuals: sigma^2
  /// (J^T J)^-1 of the Sampson errors over rotation and translation direction. Scale-free poses
  /// have no variance along the translation (it is a direction).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

/// Variance (m^2) a published scale-free pose carries along its translation direction, whose
/// length is unknown (sd 1000 m): its covariance is then invertible, and a backend that inverts it
/// gets next to no information along the direction and the measured one across it.
constexpr double kUnknownScaleVariance = 1e6;

/// A scale-free pose as it is published: kUnknownScaleVariance added along the unit translation
/// (a direction has no variance along itself, so the covariance alone has rank 5). Metric poses
/// are returned unchanged.
RelativePose withUnknownScale(RelativePose pose);

struct VerificationResult {
  VerificationVerdict verdict = VerificationVerdict::kNoIntrinsics;
  int matches = 0;
  int inliers = 0;
  double spread = 0.0;            ///< Share of grid cells holding inliers.
  double rms_error_px = 0.0;      ///< RMS Sampson error of the inliers, pixels.
  double parallax_deg = 0.0;      ///< Median angle between matched rays after rotation.
  double rotation_sd_deg = 0.0;   ///< Square root of the rotation covariance's trace.
  double direction_sd_deg = 0.0;  ///< Same for the translation direction (scale-free poses).
  RelativePose pose;              ///< Meaningful when verdict is kAccepted.
  std::vector<std::pair<cv::Point2f, cv::Point2f>> inlier_pairs;  ///< Query, match pixels.

  /// The pose is well determined (and the place confirmed).
  bool accepted() const { return verdict == VerificationVerdict::kAccepted; }
  /// Enough well-spread matches agree with one two-view geometry: the same place, even when the
  /// pose itself is ambiguous or has no translation (pure rotation).
  bool placeConfirmed() const {
    return verdict == VerificationVerdict::kAccepted ||
           verdict == VerificationVerdict::kAmbiguous ||
           verdict == VerificationVerdict::kNoParallax;
  }
};

/// (query index, match index) of ORB matches passing Lowe's ratio test, at most one per match
/// keypoint (the closest).
std::vector<std::pair<int, int>> ratioTestMatches(const LocalFeatures& query,
                                                  const LocalFeatures& match, double ratio_test);

/// Geometric check of a loop candidate: ORB matches between the two keyframes, an essential
/// matrix by RANSAC with the camera intrinsics, the relative rotation and translation direction,
/// refused when the inliers are too few, bunched together or without parallax.
/// Immutable after construction; safe to call from several threads.
class GeometricVerifier {
 public:
  explicit GeometricVerifier(const VerificationOptions& options);

  /// `image`: 8-bit grey.
  LocalFeatures extract(const cv::Mat& image) const;
  /// The keypoints a keyframe keeps of a camera image (grey or colour, any size): found on the
  /// image shrunk to max_image_width and, where `intrinsics` has a lens model, moved to the ideal
  /// pixels of a pinhole camera with the same K, which every check after assumes.
  LocalFeatures extractKeyframe(const cv::Mat& image, const CameraIntrinsics& intrinsics) const;
  /// Both feature sets must come from images of the size `intrinsics` refers to.
  VerificationResult verify(const LocalFeatures& query, const LocalFeatures& match,
                            const CameraIntrinsics& intrinsics) const;

 private:
  VerificationOptions options_;
};

}  // namespace landmark_loop_closure
