// Geometric verification on rendered image pairs with known relative poses, and the degenerate
// cases it must refuse with their reason.
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/sim/corridor_world.h"
#include "textured_room.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

const CameraModel kCamera;
const cv::Size kImageSize(kCamera.width, kCamera.height);

CameraIntrinsics intrinsics() { return kCamera.intrinsics(); }

cv::Mat render(const Pose2D& pose, uint32_t noise_seed) {
  static const CorridorWorld world;
  return world.render(pose, kCamera, Lighting{}, noise_seed);
}

double angleDegrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace

double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Random nearby viewpoints (0.1-0.8 m apart, up to 11 degrees of turn) in a textured room, the
// scale-free pose from two views. Tolerances are those measured on these pairs: the typical
// accepted pose is within a fraction of a degree, but a minority sits in a second minimum the
// matches cannot rule out (why publish_scale_free_pose is off by default). Pairs whose pose is
// refused are refused for their geometry (ambiguous, no parallax): the place is still confirmed.
TEST(GeometricVerification, ScaleFreePosesOnGeneratedPairsMatchTheTruth) {
  const test::TexturedRoom room;
  const GeometricVerifier verifier(VerificationOptions{});
  cv::RNG rng(5);
  constexpr int kPairs = 40;
  std::vector<double> rotation_errors;
  std::vector<double> direction_errors;
  int within_tolerance = 0;
  for (int pair = 0; pair < kPairs; ++pair) {
    SCOPED_TRACE("pair " + std::to_string(pair));
    const double x = rng.uniform(-1.5, 1.5);
    const double y = rng.uniform(-1.0, 1.0);
    const double yaw = rng.uniform(-M_PI, M_PI);
    const Eigen::Isometry3d match = test::cameraPose(x, y, 1.3, yaw);
    const Eigen::Isometry3d query = test::cameraPose(
        x + rng.uniform(-0.6, 0.6), y + rng.uniform(-0.6, 0.6), 1.3 + rng.uniform(-0.1, 0.1),
        yaw + rng.uniform(-0.2, 0.2), rng.uniform(-0.05, 0.05));
    const VerificationResult result = verifier.verify(
        verifier.extract(room.render(query, kCamera.focal_px, kImageSize)),
        verifier.extract(room.render(match, kCamera.focal_px, kImageSize)), intrinsics());
    if (!result.accepted()) {
      // Still the same place: enough matches agree with one geometry, only the pose is open.
      EXPECT_TRUE(result.placeConfirmed()) << toString(result.verdict);
      continue;
    }
    const Eigen::Isometry3d truth = query.inverse() * match;  // T_query_match.
    const double rotation_error =
        Eigen::AngleAxisd(result.pose.rotation * truth.linear().transpose()).angle() * 180.0 / M_PI;
    const double direction_error = angleDegrees(result.pose.translation, truth.translation());
    rotation_errors.push_back(rotation_error);
    direction_errors.push_back(direction_error);
    within_tolerance += rotation_error < 1.5 && direction_error < 8.0 ? 1 : 0;
    EXPECT_FALSE(result.pose.metric);
    EXPECT_NEAR(result.pose.translation.norm(), 1.0, 1e-9);
    EXPECT_LT(result.rms_error_px, 1.0);
    EXPECT_GE(result.spread, 0.25);
    EXPECT_GE(result.inliers, 30);
    EXPECT_EQ(result.inlier_pairs.size(), static_cast<size_t>(result.inliers));
    EXPECT_LE(result.rotation_sd_deg, 1.0);
    EXPECT_LE(result.direction_sd_deg, 5.0);
    // The covariance: symmetric, positive on the rotation, nothing along the unit translation.
    const Eigen::Matrix<double, 6, 6>& covariance = result.pose.covariance;
    EXPECT_LT((covariance - covariance.transpose()).norm(), 1e-12);
    for (int i = 3; i < 6; ++i) EXPECT_GT(covariance(i, i), 0.0);
    EXPECT_NEAR((covariance.block<3, 3>(0, 0) * result.pose.translation).norm(), 0.0, 1e-9);
  }
  const int accepted = static_cast<int>(rotation_errors.size());
  ASSERT_GE(accepted, kPairs / 2);
  std::cout << accepted << " of " << kPairs << " pairs accepted, " << within_tolerance
            << " within 1.5 deg / 8 deg; median error rotation " << median(rotation_errors)
            << " deg, direction " << median(direction_errors) << " deg\n";
  EXPECT_LT(median(rotation_errors), 1.0);
  EXPECT_LT(median(direction_errors), 6.0);
  EXPECT_GE(within_tolerance, accepted / 2);
}

TEST(GeometricVerification, NoTextureIsRefused) {
  const GeometricVerifier verifier(VerificationOptions{});
  const cv::Mat blank(kCamera.height, kCamera.width, CV_8UC1, cv::Scalar(0));
  const VerificationResult result =
      verifier.verify(verifier.extract(blank), verifier.extract(blank), intrinsics());
  EXPECT_EQ(result.verdict, VerificationVerdict::kTooFewFeatures);
}

// Turning on the spot: the place is confirmed, but without parallax there is no translation, so
// no pose.
TEST(GeometricVerification, PureRotationConfirmsThePlaceButGivesNoPose) {
  const test::TexturedRoom room;
  const GeometricVerifier verifier(VerificationOptions{});
  const VerificationResult result =
      verifier.verify(verifier.extract(room.render(test::cameraPose(0.5, 0.2, 1.3, 0.4),
                                                   kCamera.focal_px, kImageSize)),
                      verifier.extract(room.render(test::cameraPose(0.5, 0.2, 1.3, 0.3),
                                                   kCamera.focal_px, kImageSize)),
                      intrinsics());
  EXPECT_EQ(result.verdict, VerificationVerdict::kNoParallax) << toString(result.verdict);
  EXPECT_GT(result.inliers, 50);  // Plenty of matches: the pose is refused for the geometry alone.
  EXPECT_LT(result.parallax_deg, 1.0);
  EXPECT_TRUE(result.placeConfirmed());
  EXPECT_FALSE(result.accepted());
}

TEST(GeometricVerification, DifferentPlacesAreRefused) {
  const CorridorWorld world;
  const GeometricVerifier verifier(VerificationOptions{});
  for (const double s : {10.0, 30.0}) {
    const VerificationResult result =
        verifier.verify(verifier.extract(render(world.poseAt(s, 0.0), 1)),
                        verifier.extract(render(world.poseAt(s + 12.0, 0.0), 2)), intrinsics());
    EXPECT_FALSE(result.placeConfirmed())
        << toString(result.verdict) << ", " << result.inliers << " inliers";
  }
  // Opposite walls of the textured room: rich texture, nothing in common.
  const test::TexturedRoom room;
  const VerificationResult opposite =
      verifier.verify(verifier.extract(room.render(test::cameraPose(0.0, 0.0, 1.3, 0.0),
                                                   kCamera.focal_px, kImageSize)),
                      verifier.extract(room.render(test::cameraPose(0.0, 0.0, 1.3, M_PI),
                                                   kCamera.focal_px, kImageSize)),
                      intrinsics());
  EXPECT_FALSE(opposite.placeConfirmed()) << toString(opposite.verdict);
}

TEST(GeometricVerification, WithoutIntrinsicsNothingIsVerified) {
  const CorridorWorld world;
  const GeometricVerifier verifier(VerificationOptions{});
  const LocalFeatures features = verifier.extract(render(world.poseAt(6.0, 0.0), 1));
  EXPECT_EQ(verifier.verify(features, features, CameraIntrinsics{}).verdict,
            VerificationVerdict::kNoIntrinsics);
  CameraIntrinsics nan = intrinsics();
  nan.fx = std::nan("");
  EXPECT_FALSE(nan.valid());
  // Wrong-type images give no features rather than an exception.
  EXPECT_TRUE(verifier.extract(cv::Mat(10, 10, CV_32FC1, cv::Scalar(0))).empty());
}

TEST(GeometricVerification, IntrinsicsScaleWithTheImage) {
  const CameraIntrinsics half = intrinsics().scaledTo(cv::Size(160, 120));
  EXPECT_DOUBLE_EQ(half.fx, 100.0);
  EXPECT_DOUBLE_EQ(half.cx, 79.5);  // The centre of a 160-pixel row.
  EXPECT_DOUBLE_EQ(half.cy, 59.5);
}

TEST(GeometricVerification, OptionsAreValidated) {
  EXPECT_EQ(VerificationOptions{}.validate(), "");
  VerificationOptions options;
  options.min_inliers = 3;
  options.ratio_test = 1.5;
  options.min_spread = 2.0;
  const std::string errors = options.validate();
  for (const char* key : {"min_inliers", "ratio_test", "min_spread"}) {
    EXPECT_NE(errors.find(key), std::string::npos) << key;
  }
}

TEST(CameraIntrinsics, EachUnusableCalibrationHasItsOwnCauseAndNamesTheField) {
  CameraIntrinsics good;
  good.fx = good.fy = 200.0;
  good.cx = 159.5;
  good.cy = 119.5;
  good.image_size = cv::Size(320, 240);
  EXPECT_EQ(good.problem(), "");
  EXPECT_FALSE(good.checkFor(cv::Size(640, 480))) << "the same camera at twice the size";

  struct Case {
    std::function<void(CameraIntrinsics*)> spoil;
    std::string cause;
    std::string says;
  };
  const std::vector<Case> cases = {
      {[](CameraIntrinsics* k) { k->fx = k->fy = k->cx = k->cy = 0.0; }, "no_calibration",
       "K is all zeros"},
      {[](CameraIntrinsics* k) { k->fx = -200.0; }, "focal_not_positive",
       "fx -200, fy 200 must both be positive"},
      {[](CameraIntrinsics* k) { k->cy = std::nan(""); }, "non_finite", "non-finite"},
      {[](CameraIntrinsics* k) { k->fx = std::numeric_limits<double>::infinity(); }, "non_finite",
       "non-finite"},
      {[](CameraIntrinsics* k) { k->image_size = cv::Size(0, 0); }, "empty_size", "is empty"},
      {[](CameraIntrinsics* k) { k->fx = k->fy = 1e-12; }, "focal_implausible",
       "16 to 32000 px for 320 px"},
      {[](CameraIntrinsics* k) { k->fx = k->fy = 15.9; }, "focal_implausible", "0.05 and 100"},
      {[](CameraIntrinsics* k) { k->fx = k->fy = 1e300; }, "focal_implausible", "image widths"},
      {[](CameraIntrinsics* k) { k->fy = 401.0; }, "pixel_aspect", "factor of 2"},
      {[](CameraIntrinsics* k) { k->cx = 900.0; }, "principal_point", "principal point (900"},
      {[](CameraIntrinsics* k) { k->cx = k->cy = 0.0; }, "principal_point", "middle 80 %"},
      {[](CameraIntrinsics* k) { k->cy = 220.0; }, "principal_point", "320x240 image"},
  };
  for (const Case& c : cases) {
    CameraIntrinsics spoilt = good;
    c.spoil(&spoilt);
    const std::optional<CalibrationProblem> found = spoilt.check();
    ASSERT_TRUE(found) << c.cause;
    EXPECT_FALSE(spoilt.valid());
    EXPECT_EQ(found->cause, c.cause) << found->text;
    EXPECT_NE(found->text.find(c.says), std::string::npos) << found->text;
    EXPECT_EQ(spoilt.problem(), found->text);
  }
  CameraIntrinsics edge = good;  // The rule's limits themselves are usable.
  edge.fx = 16.0;
  edge.fy = 32.0;
  edge.cx = 32.0;
  edge.cy = 216.0;
  EXPECT_TRUE(edge.valid()) << edge.problem();
  const std::optional<CalibrationProblem> other = good.checkFor(cv::Size(640, 360));
  ASSERT_TRUE(other);
  EXPECT_EQ(other->cause, "aspect_ratio");
  EXPECT_NE(other->text.find("aspect ratio"), std::string::npos);
}

// A direction has no variance along itself: published as it is, a scale-free pose's covariance
// has rank 5 and a backend inverting it gets infinities.
TEST(GeometricVerification, PublishedScaleFreeCovarianceIsInvertible) {
  RelativePose pose;
  pose.translation = Eigen::Vector3d(0.6, 0.0, 0.8);
  const Eigen::Vector3d across_a(0.8, 0.0, -0.6);
  const Eigen::Vector3d across_b(0.0, 1.0, 0.0);
  pose.covariance.block<3, 3>(0, 0) =
      1e-4 * (across_a * across_a.transpose()) + 2e-4 * (across_b * across_b.transpose());
  pose.covariance.block<3, 3>(3, 3) = 1e-6 * Eigen::Matrix3d::Identity();
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  ASSERT_LT(Eigen::FullPivLU<Matrix6>(pose.covariance).rank(), 6);

  const RelativePose published = withUnknownScale(pose);
  const Eigen::SelfAdjointEigenSolver<Matrix6> eigen(published.covariance);
  EXPECT_GT(eigen.eigenvalues().minCoeff(), 0.0);
  const Eigen::Vector3d along = pose.translation;
  EXPECT_NEAR(along.dot(published.covariance.block<3, 3>(0, 0) * along), kUnknownScaleVariance,
              1e-6);
  // Across the direction and in rotation nothing changes.
  EXPECT_NEAR(across_a.dot(published.covariance.block<3, 3>(0, 0) * across_a), 1e-4, 1e-9);
  EXPECT_NEAR(across_b.dot(published.covariance.block<3, 3>(0, 0) * across_b), 2e-4, 1e-9);
  const Eigen::Matrix3d rotation_before = pose.covariance.block<3, 3>(3, 3);
  const Eigen::Matrix3d rotation_after = published.covariance.block<3, 3>(3, 3);
  EXPECT_TRUE(rotation_after.isApprox(rotation_before));
  // What a backend sees after inverting: almost no information along the direction.
  const Matrix6 information = published.covariance.inverse();
  EXPECT_LT(along.dot(information.block<3, 3>(0, 0) * along), 1e-5);
  EXPECT_GT(across_a.dot(information.block<3, 3>(0, 0) * across_a), 1e3);

  RelativePose metric = pose;
  metric.metric = true;
  EXPECT_TRUE(withUnknownScale(metric).covariance.isApprox(metric.covariance));
}
