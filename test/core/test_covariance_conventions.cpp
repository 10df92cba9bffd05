// LoopClosure.relative_pose's covariance converted for Ceres' pose_graph_3d and GTSAM's Pose3:
// noise drawn with our covariance in our convention, pushed through each backend's own error
// term, must have the converted covariance.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "landmark_loop_closure/geometry/covariance_conventions.h"

namespace landmark_loop_closure {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

struct RelativePose {
  Eigen::Vector3d t;
  Eigen::Quaterniond q;
};

/// A loop's covariance with strong correlations between position and rotation (a pose seen from
/// one side: moving sideways and turning explain the same image motion), small enough for first
/// order to hold.
Matrix6 correlatedCovariance() {
  Matrix6 root;
  root << 3, 0, 0, 0, 0, 0,  //
      1, 2, 0, 0, 0, 0,      //
      0, 1, 4, 0, 0, 0,      //
      0, 0, 1, 1, 0, 0,      //
      0, 2, 0, 0, 1, 0,      //
      2, 0, 0, 1, 0, 2;
  return 1e-6 * root * root.transpose();
}

/// A relative pose with a real rotation (about 70 degrees about a tilted axis).
RelativePose publishedPose() {
  return {Eigen::Vector3d(1.5, -0.4, 0.3),
          Eigen::Quaterniond(Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()))};
}

Eigen::Quaterniond exponential(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

Eigen::Vector3d logarithm(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd angle_axis(q);
  return angle_axis.angle() * angle_axis.axis();
}

/// Measurements of `truth` with our convention's noise: t' = t + dt, R' = exp(w) R.
template <typename ErrorTerm>
Matrix6 errorCovariance(const Matrix6& covariance, const RelativePose& truth, ErrorTerm error) {
  const Matrix6 root = covariance.llt().matrixL();
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  const int samples = 40000;
  Matrix6 sum = Matrix6::Zero();
  for (int i = 0; i < samples; ++i) {
    Vector6 unit;
    for (int k = 0; k < 6; ++k) unit[k] = normal(random);
    const Vector6 noise = root * unit;
    const RelativePose measured{truth.t + noise.head<3>(), exponential(noise.tail<3>()) * truth.q};
    const Vector6 residual = error(measured, truth);
    sum += residual * residual.transpose();
  }
  return sum / samples;
}

/// Ceres' examples/slam/pose_graph_3d error term, the estimate being the truth: (p_est - p_meas,
/// 2 vec(q_meas * q_est^-1)).
Vector6 ceresError(const RelativePose& measured, const RelativePose& estimate) {
  Vector6 residual;
  residual.head<3>() = estimate.t - measured.t;
  residual.tail<3>() = 2.0 * (measured.q * estimate.q.conjugate()).vec();
  return residual;
}

/// GTSAM's BetweenFactor<Pose3> error, Logmap(measured^-1 * estimate), to first order: rotation
/// Log(R_meas^T R_est), then translation R_meas^T (t_est - t_meas).
Vector6 gtsamError(const RelativePose& measured, const RelativePose& estimate) {
  Vector6 residual;
  residual.head<3>() = logarithm(measured.q.conjugate() * estimate.q);
  residual.tail<3>() = measured.q.conjugate() * (estimate.t - measured.t);
  return residual;
}

double relativeDifference(const Matrix6& a, const Matrix6& b) { return (a - b).norm() / b.norm(); }

TEST(CovarianceConventions, CeresPoseGraph3dErrorHasTheConvertedCovariance) {
  const Matrix6 ours = correlatedCovariance();
  const RelativePose truth = publishedPose();
  const Matrix6 sampled = errorCovariance(ours, truth, ceresError);
  EXPECT_LT(relativeDifference(sampled, ceresPoseGraph3dCovariance(ours)), 0.03);
  // What the README said before: the rotation block turned by R^T. Far off with a real rotation.
  Matrix6 turned = Matrix6::Identity();
  turned.block<3, 3>(3, 3) = truth.q.toRotationMatrix().transpose();
  EXPECT_GT(relativeDifference(sampled, turned * ours * turned.transpose()), 0.2);
  // Ours as it is (the cross terms' sign) is off too.
  EXPECT_GT(relativeDifference(sampled, ours), 0.2);
}

TEST(CovarianceConventions, GtsamPose3ErrorHasTheConvertedCovariance) {
  const Matrix6 ours = correlatedCovariance();
  const RelativePose truth = publishedPose();
  const Matrix6 sampled = errorCovariance(ours, truth, gtsamError);
  EXPECT_LT(relativeDifference(sampled, gtsamPose3Covariance(ours, truth.q.toRotationMatrix())),
            0.03);
}

TEST(CovarianceConventions, WithoutCrossTermsCeresNeedsNoConversion) {
  Matrix6 diagonal = Matrix6::Zero();
  diagonal.diagonal() << 1e-4, 2e-4, 3e-4, 1e-6, 2e-6, 3e-6;
  EXPECT_TRUE(ceresPoseGraph3dCovariance(diagonal).isApprox(diagonal));
}

}  // namespace
}  // namespace landmark_loop_closure
