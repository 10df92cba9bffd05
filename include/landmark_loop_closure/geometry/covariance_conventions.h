#pragma once

#include <Eigen/Core>

namespace landmark_loop_closure {

/// LoopClosure.relative_pose's covariance in the conventions of common pose-graph backends. Ours
/// is ordered (x, y, z, rotation about x, y, z) for the error t' = t + dt, R' = exp(w) R, both in
/// the query's frame (pose_jacobian.h). Header-only, Eigen only: a backend can include it or copy
/// the few lines. To first order; checked by sampling in test_covariance_conventions.

/// Ceres' pose_graph_3d example (PoseGraph3dErrorTerm): residual (p_est - p_meas,
/// 2 vec(q_meas * q_est^-1)), position first, the rotation error on the left as ours but with
/// the opposite sign (measured times estimate's inverse), so only the cross terms between
/// position and rotation change sign. Its sqrt_information is then
/// ceresPoseGraph3dCovariance(ours).inverse().llt().matrixL().transpose().
inline Eigen::Matrix<double, 6, 6> ceresPoseGraph3dCovariance(
    const Eigen::Matrix<double, 6, 6>& ours) {
  Eigen::Matrix<double, 6, 6> converted = ours;
  converted.block<3, 3>(0, 3) = -ours.block<3, 3>(0, 3);
  converted.block<3, 3>(3, 0) = -ours.block<3, 3>(3, 0);
  return converted;
}

/// GTSAM's Pose3 (BetweenFactor<Pose3>(query, match, T, noise)): tangent (rotation, translation)
/// with T' = T * Exp(xi), so xi = (R^T w, R^T dt) for the relative pose's rotation R: a
/// Gaussian noise model with this covariance.
inline Eigen::Matrix<double, 6, 6> gtsamPose3Covariance(const Eigen::Matrix<double, 6, 6>& ours,
                                                        const Eigen::Matrix3d& rotation) {
  Eigen::Matrix<double, 6, 6> to_gtsam = Eigen::Matrix<double, 6, 6>::Zero();
  to_gtsam.block<3, 3>(0, 3) = rotation.transpose();
  to_gtsam.block<3, 3>(3, 0) = rotation.transpose();
  return to_gtsam * ours * to_gtsam.transpose();
}

}  // namespace landmark_loop_closure
