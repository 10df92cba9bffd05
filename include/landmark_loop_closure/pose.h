#pragma once

#include <Eigen/Geometry>

namespace landmark_loop_closure {

/// A rigid body pose in the odometry frame: position in metres, orientation as a unit quaternion.
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();

  Eigen::Isometry3d toIsometry() const;
  static Pose fromIsometry(const Eigen::Isometry3d& transform);
};

/// Roll, pitch and yaw (radians) of a rotation, each in [-pi, pi].
Eigen::Vector3d rollPitchYaw(const Eigen::Quaterniond& rotation);

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
