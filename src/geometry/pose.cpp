#include "landmark_loop_closure/geometry/pose.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {

Eigen::Isometry3d Pose::toIsometry() const {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = orientation.normalized().toRotationMatrix();
  transform.translation() = position;
  return transform;
}

Pose Pose::fromIsometry(const Eigen::Isometry3d& transform) {
  Pose pose;
  pose.position = transform.translation();
  pose.orientation = Eigen::Quaterniond(transform.linear()).normalized();
  return pose;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

BodyLoop loopBetweenBodies(const Eigen::Isometry3d& camera_query_T_match,
                           const Eigen::Matrix<double, 6, 6>& camera_covariance,
                           const Eigen::Isometry3d& query_mount,
                           const Eigen::Isometry3d& match_mount) {
  BodyLoop loop;
  loop.query_T_match = query_mount * camera_query_T_match * match_mount.inverse();
  // R_B = R_q R R_m^T and t_B = R_q t + p_q - R_B p_m: a left rotation w of R becomes R_q w, and
  // turning p_m with it moves t_B by (R_B p_m) x (R_q w).
  const Eigen::Matrix3d query_rotation = query_mount.rotation();
  const Eigen::Vector3d lever = loop.query_T_match.rotation() * match_mount.translation();
  Eigen::Matrix<double, 6, 6> jacobian = Eigen::Matrix<double, 6, 6>::Zero();
  jacobian.block<3, 3>(0, 0) = query_rotation;
  jacobian.block<3, 3>(0, 3) = skew(lever) * query_rotation;
  jacobian.block<3, 3>(3, 3) = query_rotation;
  loop.covariance = jacobian * camera_covariance * jacobian.transpose();
  loop.covariance = 0.5 * (loop.covariance + loop.covariance.transpose());
  return loop;
}

Eigen::Matrix3d scaledRotationMatrix(const Eigen::Quaterniond& q) {
  // (w^2 - |v|^2) I + 2 v v^T + 2 w [v]x: the unit-quaternion formula with 1 = w^2 + |v|^2 kept
  // as it is, so every entry scales with the squared length.
  const Eigen::Vector3d v = q.vec();
  Eigen::Matrix3d cross;
  cross << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return (q.w() * q.w() - v.squaredNorm()) * Eigen::Matrix3d::Identity() + 2.0 * v * v.transpose() +
         2.0 * q.w() * cross;
}

bool isRotation(const Eigen::Matrix3d& matrix, double tolerance) {
  if (!matrix.allFinite()) return false;
  const double off =
      (matrix.transpose() * matrix - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return off <= tolerance && matrix.determinant() > 0.0;
}

Eigen::Vector3d rollPitchYaw(const Eigen::Quaterniond& rotation) {
  // ZYX convention, written out so that the angles stay in [-pi, pi] rather than Eigen's
  // eulerAngles() ranges, which would make a small rotation look like a large one.
  const Eigen::Quaterniond q = rotation.normalized();
  const double sin_roll_cos_pitch = 2.0 * (q.w() * q.x() + q.y() * q.z());
  const double cos_roll_cos_pitch = 1.0 - 2.0 * (q.x() * q.x() + q.y() * q.y());
  const double roll = std::atan2(sin_roll_cos_pitch, cos_roll_cos_pitch);
  const double sin_pitch = std::clamp(2.0 * (q.w() * q.y() - q.z() * q.x()), -1.0, 1.0);
  const double pitch = std::asin(sin_pitch);
  const double sin_yaw_cos_pitch = 2.0 * (q.w() * q.z() + q.x() * q.y());
  const double cos_yaw_cos_pitch = 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z());
  const double yaw = std::atan2(sin_yaw_cos_pitch, cos_yaw_cos_pitch);
  return {roll, pitch, yaw};
}

Pose planarPose(double x, double y, double yaw) {
  Pose pose;
  pose.position = Eigen::Vector3d(x, y, 0.0);
  pose.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

Pose CameraMount::toPose() const {
  Pose pose;
  pose.position = Eigen::Vector3d(x, y, z);
  pose.orientation = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  return pose;
}

const ParameterTable<CameraMount>& CameraMount::parameters() {
  using O = CameraMount;
  static const auto table =
      ParameterTable<O>("camera_mount/",
                        "where does the camera sit on the robot (base_frame -> camera optical "
                        "frame)? Leave these unset when tf has that transform (a URDF, "
                        "static_transform_publisher): it is looked up. The mount turns the "
                        "odometry's motion into the camera's, for triangulation, and "
                        "camera-frame relative poses into base_frame ones.")
          .number("x", &O::x, anyFinite(),
                  "metres, in the odometry's body frame (x forward, y left, z up).")
          .number("y", &O::y, anyFinite(), "")
          .number("z", &O::z, anyFinite(), "")
          .number("roll", &O::roll, anyFinite(),
                  "radians, fixed axes, as static_transform_publisher takes them;")
          .number("pitch", &O::pitch, anyFinite(),
                  "the default is a camera looking along the body's x axis.")
          .number("yaw", &O::yaw, anyFinite(), "");
  return table;
}

std::string CameraMount::validate() const { return parameters().check(*this); }

bool CameraMount::isDefault() const {
  const CameraMount unset;
  return x == unset.x && y == unset.y && z == unset.z && roll == unset.roll &&
         pitch == unset.pitch && yaw == unset.yaw;
}

PathLength extendPath(const PathLength& path, const Pose& from, const Pose& to) {
  PathLength extended = path;
  extended.metres += (to.position - from.position).norm();
  extended.radians += from.orientation.angularDistance(to.orientation);
  return extended;
}

}  // namespace landmark_loop_closure
