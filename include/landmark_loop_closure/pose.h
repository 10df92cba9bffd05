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

}  // namespace landmark_loop_closure
