#pragma once

#include <cmath>
#include <string>

#include <Eigen/Geometry>

#include "landmark_loop_closure/common/parameter_table.h"

namespace landmark_loop_closure {

/// No odometry reaches this far from its origin (m, per coordinate): a position beyond it is a
/// corrupt message. Far beyond it, squared distances overflow and poses built from them turn into
/// NaN.
constexpr double kMaxPoseCoordinateM = 1e9;

/// A rigid body pose in the odometry frame: position in metres, orientation as a unit quaternion.
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();

  Eigen::Isometry3d toIsometry() const;
  static Pose fromIsometry(const Eigen::Isometry3d& transform);
};

/// The cross-product matrix: skew(v) w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

/// The rotation matrix of q scaled by q's squared length, q not normalised first: a quaternion
/// that is not of unit length (all zeros, a forgotten w) gives a matrix that is not a rotation,
/// for the receiver to refuse, where normalising would have read all zeros as no rotation.
Eigen::Matrix3d scaledRotationMatrix(const Eigen::Quaterniond& q);

/// Whether a matrix is a rotation: R^T R within `tolerance` of identity, determinant positive.
bool isRotation(const Eigen::Matrix3d& matrix, double tolerance);

/// Roll, pitch and yaw (radians) of a rotation, each in [-pi, pi].
Eigen::Vector3d rollPitchYaw(const Eigen::Quaterniond& rotation);

/// Where a camera's optical frame (x right, y down, z forward) sits on the robot's body frame (x
/// forward, y left, z up): position in metres, orientation as fixed-axis roll, pitch, yaw
/// (radians, applied in that order, as tf's static_transform_publisher takes them). The default
/// is a camera at the body's origin looking along its x axis.
struct CameraMount {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
  double roll = -M_PI / 2.0;
  double pitch = 0.0;
  double yaw = -M_PI / 2.0;

  Pose toPose() const;
  /// Every value is the default: none was set (tf is then asked first, where it has the mount).
  bool isDefault() const;
  /// Keys under camera_mount/, documented in config/default.yaml.
  static const ParameterTable<CameraMount>& parameters();
  std::string validate() const;
};

/// A loop's relative transform T_query_match between two cameras, re-expressed between the
/// bodies that carry them: B = M_query T M_match^-1, where M_query and M_match are where each
/// camera sits on its own body (base_T_camera; two robots' mounts may differ). The covariance
/// (order and convention of LoopClosure.relative_pose: translation added, rotation applied on the
/// left, both in the query's frame) follows to first order: a camera-frame step (dt, w) moves B by
/// (R_q dt + [R_B p_match]x R_q w, R_q w). The one conjugation every loop goes through (the
/// detector's relative_pose_frame: base, the reference backend).
struct BodyLoop {
  Eigen::Isometry3d query_T_match = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};
BodyLoop loopBetweenBodies(const Eigen::Isometry3d& camera_query_T_match,
                           const Eigen::Matrix<double, 6, 6>& camera_covariance,
                           const Eigen::Isometry3d& query_mount,
                           const Eigen::Isometry3d& match_mount);

/// Pose with yaw only about +z, for planar robots and tests.
Pose planarPose(double x, double y, double yaw);

/// Odometry path accumulated up to a keyframe, summed over consecutive keyframes.
struct PathLength {
  double metres = 0.0;
  double radians = 0.0;
};

/// The path after moving from `from` to `to`.
PathLength extendPath(const PathLength& path, const Pose& from, const Pose& to);

}  // namespace landmark_loop_closure
