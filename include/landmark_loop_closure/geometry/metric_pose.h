#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// How keypoints of a keyframe get depths, and when a metric loop pose is good enough.
struct MetricPoseOptions {
  /// Triangulate each keyframe's keypoints against the previous keyframe, with the camera motion
  /// between them from the odometry (its drift over one keyframe step is negligible).
  bool triangulate_from_odometry = true;
  /// Rays meeting at a smaller angle give depths too noisy to use.
  double min_triangulation_angle_deg = 1.5;
  double max_point_depth_m = 40.0;  ///< Farther points (or depth readings) are dropped.
  /// Reprojection error a triangulated point may have in either keyframe, and the PnP inlier
  /// threshold (pixels).
  double max_reprojection_px = 2.0;
  int min_inliers = 20;                        ///< Fewer PnP inliers: no metric pose.
  double max_translation_sd_m = 0.25;          ///< Larger translation uncertainty: no metric pose.
  double max_rotation_sd_deg = 1.0;            ///< Same for the rotation.
  double depth_image_metres_per_unit = 0.001;  ///< 16-bit depth images (mm); float ones are m.
  /// Depth-image noise: standard deviation = this * depth^2 (structured light and stereo grow
  /// with the square of the distance).
  double depth_image_sd_per_m2 = 0.003;

  /// Keys under metric_pose/, documented in config/default.yaml.
  static const ParameterTable<MetricPoseOptions>& parameters();
  std::string validate() const;
};

/// A metric relative pose from 2D query keypoints and 3D match keypoints.
struct MetricPoseResult {
  bool found = false;
  std::string failure;  ///< Why not, when found is false.
  int candidates = 0;   ///< Matches whose match keypoint has a depth.
  int inliers = 0;
  double rms_error_px = 0.0;
  RelativePose pose;  ///< metric = true; covariance sigma^2 (J^T J)^-1 of reprojections.
  /// Query pixels of the inliers, with the match pixels they were matched to.
  std::vector<std::pair<cv::Point2f, cv::Point2f>> inlier_pairs;
};

/// Depths for `keyframe`'s keypoints from a second view whose camera pose in the keyframe's
/// camera frame is `neighbour_in_keyframe` (optical axes, metres): ratio-test matches that
/// agree with that motion are triangulated (ratio test and keypoint noise from `verification`).
/// Fills keyframe->points3d and depth_sd, keeping a depth found earlier (from another view)
/// where it is the more certain; returns how many keypoints this view triangulated.
int triangulateKeypoints(const LocalFeatures& neighbour,
                         const Eigen::Isometry3d& neighbour_in_keyframe,
                         const CameraIntrinsics& intrinsics,
                         const VerificationOptions& verification, const MetricPoseOptions& options,
                         LocalFeatures* keyframe);

/// Whether a depth image (16-bit unsigned or 32-bit float) holds at least one finite positive
/// reading; one that does not (all zero, NaN, Inf or negative) gives no depth at all.
bool hasUsableDepth(const cv::Mat& depth);

/// Depths for `keyframe`'s keypoints from a depth image registered to its camera (any size:
/// keypoints are scaled to it). 16-bit unsigned depths are multiplied by
/// depth_image_metres_per_unit, 32-bit float ones are metres; zero, NaN and out-of-range
/// readings give no point. Returns how many keypoints got one.
int keypointsFromDepth(const cv::Mat& depth, const CameraIntrinsics& intrinsics,
                       const MetricPoseOptions& options, LocalFeatures* keyframe);

/// T_query_match with metric translation: RANSAC PnP of the query keypoints against the 3D
/// keypoints of the match, refined by Levenberg-Marquardt on the reprojection errors weighted by
/// each point's expected error (keypoint noise, verification.keypoint_sigma_px, and its depth
/// uncertainty); the covariance is (J^T J)^-1 of the weighted problem, widened when the residuals
/// spread more than expected.
/// `matches`: (query index, match index) pairs, e.g. from ratioTestMatches().
MetricPoseResult estimateMetricPose(const LocalFeatures& query, const LocalFeatures& match,
                                    const std::vector<std::pair<int, int>>& matches,
                                    const CameraIntrinsics& intrinsics,
                                    const VerificationOptions& verification,
                                    const MetricPoseOptions& options);

/// A metric T_query_match between two camera poses re-expressed between the bodies carrying the
/// camera at `camera_mount` (the camera's pose in the body frame): M T M^-1, with the covariance
/// carried along (same order: x, y, z, rotation about x, y, z of the query body's frame).
RelativePose inBodyFrame(const RelativePose& in_camera, const Pose& camera_mount);
/// The same between two bodies whose cameras sit at different mounts (two robots):
/// M_query T M_match^-1 (loopBetweenBodies).
RelativePose inBodyFrames(const RelativePose& in_cameras, const Pose& query_mount,
                          const Pose& match_mount);

}  // namespace landmark_loop_closure
