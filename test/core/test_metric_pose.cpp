// Metric relative poses: keypoint depths from the odometry's motion between keyframes or from a
// depth image, then PnP of the query against them, on rendered views with known poses.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "landmark_loop_closure/geometry/metric_pose.h"
#include "landmark_loop_closure/geometry/pose_jacobian.h"
#include "landmark_loop_closure/sim/corridor_world.h"
#include "textured_room.h"

using namespace landmark_loop_closure;

namespace {

const sim::CameraModel kCamera;
const cv::Size kImageSize(kCamera.width, kCamera.height);
constexpr double kRadiansToDegrees = 180.0 / M_PI;

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

struct Errors {
  std::vector<double> translation_m;
  std::vector<double> rotation_deg;
  std::vector<double> mahalanobis_squared;  ///< Of the 6-dof error under the covariance.
  int found = 0;
  int within_tolerance = 0;
};

// The error of an estimated T_query_match against the truth, added to `errors`.
void record(const MetricPoseResult& result, const Eigen::Isometry3d& truth, Errors* errors) {
  const RelativePose& pose = result.pose;
  EXPECT_TRUE(pose.metric);
  const Eigen::AngleAxisd rotation_error(pose.rotation * truth.linear().transpose());
  Eigen::Matrix<double, 6, 1> error;
  error.head<3>() = pose.translation - truth.translation();
  error.tail<3>() = rotation_error.angle() * rotation_error.axis();
  const double translation = error.head<3>().norm();
  const double rotation = rotation_error.angle() * kRadiansToDegrees;
  errors->translation_m.push_back(translation);
  errors->rotation_deg.push_back(rotation);
  errors->mahalanobis_squared.push_back(error.dot(pose.covariance.ldlt().solve(error)));
  errors->within_tolerance += translation < 0.10 && rotation < 1.0 ? 1 : 0;
  ++errors->found;
  const Eigen::Matrix<double, 6, 6>& covariance = pose.covariance;
  EXPECT_LT((covariance - covariance.transpose()).norm(), 1e-12);
  for (int i = 0; i < 6; ++i) EXPECT_GT(covariance(i, i), 0.0);
  EXPECT_GE(result.inliers, 20);
  EXPECT_EQ(result.inlier_pairs.size(), static_cast<size_t>(result.inliers));
}

void report(const char* what, int trials, const Errors& errors) {
  std::vector<double> chi = errors.mahalanobis_squared;
  const double covered =
      static_cast<double>(std::count_if(chi.begin(), chi.end(),
                                        [](double d) {
                                          return d < 16.81;  // Chi-squared, 6 dof, 99 %.
                                        })) /
      std::max<size_t>(1, chi.size());
  std::cout << what << ": " << errors.found << " of " << trials << " metric, "
            << errors.within_tolerance << " within 10 cm / 1 deg; median error "
            << median(errors.translation_m) * 100.0 << " cm, " << median(errors.rotation_deg)
            << " deg; truth inside the 99 % covariance ellipsoid for " << covered * 100.0 << " %\n";
}

struct Views {
  Eigen::Isometry3d match;
  /// The three keyframes before the match, 0.25-0.45 m apart, as a robot drove to it.
  std::vector<Eigen::Isometry3d> neighbours;
  Eigen::Isometry3d query;
};

// A robot-like pair of keyframes and a revisit near them.
Views randomViews(cv::RNG& rng) {
  const double x = rng.uniform(-1.5, 1.5);
  const double y = rng.uniform(-1.0, 1.0);
  const double yaw = rng.uniform(-M_PI, M_PI);
  const double step = rng.uniform(0.25, 0.45);
  const double step_yaw = rng.uniform(-0.08, 0.08);
  Views views;
  views.match = test::cameraPose(x, y, 1.3, yaw);
  for (int back = 1; back <= 3; ++back) {
    views.neighbours.push_back(test::cameraPose(x - back * step * std::cos(yaw - back * step_yaw),
                                                y - back * step * std::sin(yaw - back * step_yaw),
                                                1.3, yaw - back * step_yaw));
  }
  views.query = test::cameraPose(x + rng.uniform(-0.6, 0.6), y + rng.uniform(-0.6, 0.6),
                                 1.3 + rng.uniform(-0.1, 0.1), yaw + rng.uniform(-0.2, 0.2),
                                 rng.uniform(-0.05, 0.05));
  return views;
}

class MetricPoseTest : public ::testing::Test {
 protected:
  LocalFeatures features(const Eigen::Isometry3d& camera) const {
    return verifier_.extract(room_.render(camera, kCamera.focal_px, kImageSize));
  }

  // The query's pose against `match` (with depths), recorded against the truth when found;
  // nullptr when not found (with a reason).
  const MetricPoseResult* estimateAndRecord(const Views& views, const LocalFeatures& match,
                                            Errors* errors) {
    const LocalFeatures query = features(views.query);
    last_ =
        estimateMetricPose(query, match, ratioTestMatches(query, match, verification_.ratio_test),
                           kCamera.intrinsics(), verification_, options_);
    if (!last_.found) {
      EXPECT_FALSE(last_.failure.empty());
      return nullptr;
    }
    record(last_, views.query.inverse() * views.match, errors);
    return &last_;
  }

  const test::TexturedRoom room_;
  const VerificationOptions verification_;
  const GeometricVerifier verifier_{verification_};
  const MetricPoseOptions options_;
  MetricPoseResult last_;
};

}  // namespace

// Depths triangulated from the keyframe before the match (the odometry's motion between them,
// here exact), then PnP: the translation is metric, unlike two views' unit direction.
TEST_F(MetricPoseTest, TriangulatedKeypointsGiveMetricPosesNearTheTruth) {
  cv::RNG rng(21);
  constexpr int kTrials = 30;
  Errors errors;
  for (int trial = 0; trial < kTrials; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Views views = randomViews(rng);
    LocalFeatures match = features(views.match);
    int depths = 0;
    for (const Eigen::Isometry3d& neighbour : views.neighbours) {
      depths += triangulateKeypoints(features(neighbour), views.match.inverse() * neighbour,
                                     kCamera.intrinsics(), verification_, options_, &match);
    }
    ASSERT_EQ(match.points3d.size(), match.points.size());
    EXPECT_GT(depths, 50);
    estimateAndRecord(views, match, &errors);
  }
  report("triangulated", kTrials, errors);
  // Measured: 30 of 30 metric, 23 within 10 cm / 1 deg, median 4.7 cm / 0.68 deg. The depths'
  // errors (3 % median) share the same few baselines, so they are correlated, which the
  // per-point covariance does not model: the truth falls inside the 99 % ellipsoid for two in
  // three loops only (docs/how_it_works.md, "Geometric verification").
  EXPECT_GE(errors.found, kTrials * 3 / 4);
  EXPECT_GE(errors.within_tolerance, errors.found * 2 / 3);
  EXPECT_LT(median(errors.translation_m), 0.06);
  EXPECT_LT(median(errors.rotation_deg), 0.8);
}

TEST_F(MetricPoseTest, DepthImageGivesMetricPosesNearTheTruth) {
  cv::RNG rng(22);
  constexpr int kTrials = 30;
  Errors errors;
  for (int trial = 0; trial < kTrials; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Views views = randomViews(rng);
    LocalFeatures match = features(views.match);
    // At twice the image's resolution, in millimetres, as many depth cameras give it.
    cv::Mat depth_mm;
    room_.renderDepth(views.match, 2.0 * kCamera.focal_px, kImageSize * 2)
        .convertTo(depth_mm, CV_16UC1, 1000.0);
    const int depths = keypointsFromDepth(depth_mm, kCamera.intrinsics(), options_, &match);
    EXPECT_EQ(depths, static_cast<int>(match.points.size()));
    const MetricPoseResult* result = estimateAndRecord(views, match, &errors);
    if (result) {
      EXPECT_LT(result->rms_error_px, 1.0);  // Exact depths: keypoint noise only.
    }
  }
  report("depth image", kTrials, errors);
  EXPECT_GE(errors.found, kTrials * 9 / 10);
  EXPECT_GE(errors.within_tolerance, errors.found * 9 / 10);
  EXPECT_LT(median(errors.translation_m), 0.03);
  EXPECT_LT(median(errors.rotation_deg), 0.3);
}

// Turning on the spot between keyframes: no baseline, so no depths (and no made-up ones).
TEST_F(MetricPoseTest, NoBaselineGivesNoDepths) {
  const Eigen::Isometry3d match = test::cameraPose(0.5, 0.2, 1.3, 0.4);
  const Eigen::Isometry3d neighbour = test::cameraPose(0.5, 0.2, 1.3, 0.3);
  LocalFeatures features_of_match = features(match);
  EXPECT_EQ(triangulateKeypoints(features(neighbour), match.inverse() * neighbour,
                                 kCamera.intrinsics(), verification_, options_, &features_of_match),
            0);
  ASSERT_EQ(features_of_match.points3d.size(), features_of_match.points.size());
  for (const cv::Point3f& p : features_of_match.points3d) EXPECT_TRUE(std::isnan(p.z));
}

// Odometry that is badly wrong between two keyframes: matches disagree with the stated motion,
// and few are triangulated instead of many wrong points.
TEST_F(MetricPoseTest, WrongMotionTriangulatesLittle) {
  cv::RNG rng(23);
  const Views views = randomViews(rng);
  LocalFeatures right = features(views.match);
  LocalFeatures wrong = right;
  const LocalFeatures neighbour = features(views.neighbours.front());
  const Eigen::Isometry3d motion = views.match.inverse() * views.neighbours.front();
  Eigen::Isometry3d wrong_motion = motion;
  wrong_motion.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()) * motion.linear();
  const int with_right = triangulateKeypoints(neighbour, motion, kCamera.intrinsics(),
                                              verification_, options_, &right);
  const int with_wrong = triangulateKeypoints(neighbour, wrong_motion, kCamera.intrinsics(),
                                              verification_, options_, &wrong);
  EXPECT_LT(with_wrong, with_right / 4);
}

TEST_F(MetricPoseTest, UnusableDepthImagesGiveNoDepths) {
  LocalFeatures match = features(test::cameraPose(0.0, 0.0, 1.3, 0.0));
  ASSERT_FALSE(match.points.empty());
  const CameraIntrinsics k = kCamera.intrinsics();
  EXPECT_EQ(keypointsFromDepth(cv::Mat(), k, options_, &match), 0);
  EXPECT_EQ(keypointsFromDepth(cv::Mat(kImageSize, CV_8UC1, cv::Scalar(3)), k, options_, &match),
            0);
  EXPECT_EQ(keypointsFromDepth(cv::Mat(kImageSize, CV_16UC1, cv::Scalar(0)), k, options_, &match),
            0);
  EXPECT_EQ(keypointsFromDepth(cv::Mat(kImageSize, CV_32FC1, cv::Scalar(NAN)), k, options_, &match),
            0);
  EXPECT_EQ(
      keypointsFromDepth(cv::Mat(kImageSize, CV_32FC3, cv::Scalar(1, 1, 1)), k, options_, &match),
      0);
  EXPECT_EQ(
      keypointsFromDepth(cv::Mat(kImageSize, CV_32FC1, cv::Scalar(100.0)), k, options_, &match),
      0);  // Beyond max_point_depth_m.
  EXPECT_EQ(keypointsFromDepth(cv::Mat(kImageSize, CV_32FC1, cv::Scalar(2.0)), CameraIntrinsics{},
                               options_, &match),
            0);
  EXPECT_EQ(match.points3d.size(), match.points.size());
}

TEST_F(MetricPoseTest, WithoutDepthsThereIsNoMetricPose) {
  const LocalFeatures match = features(test::cameraPose(0.0, 0.0, 1.3, 0.0));
  const LocalFeatures query = features(test::cameraPose(0.2, 0.1, 1.3, 0.05));
  const auto matches = ratioTestMatches(query, match, 0.8);
  ASSERT_GT(matches.size(), 30u);
  const MetricPoseResult result =
      estimateMetricPose(query, match, matches, kCamera.intrinsics(), verification_, options_);
  EXPECT_FALSE(result.found);
  EXPECT_EQ(result.failure, "the match keyframe has no depths");

  LocalFeatures few = match;
  cv::Mat depth(kImageSize, CV_32FC1, cv::Scalar(0.0));
  depth(cv::Rect(0, 0, 40, 40)).setTo(2.0);  // Depth in one corner only.
  keypointsFromDepth(depth, kCamera.intrinsics(), options_, &few);
  const MetricPoseResult too_few =
      estimateMetricPose(query, few, matches, kCamera.intrinsics(), verification_, options_);
  EXPECT_FALSE(too_few.found);
  EXPECT_NE(too_few.failure.find("have a depth"), std::string::npos) << too_few.failure;
}

TEST(MetricPoseOptions, AreValidated) {
  EXPECT_EQ(MetricPoseOptions{}.validate(), "");
  MetricPoseOptions options;
  options.min_inliers = 3;
  options.max_translation_sd_m = 0.0;
  options.depth_image_metres_per_unit = -1.0;
  const std::string problems = options.validate();
  for (const char* key : {"min_inliers", "max_translation_sd_m", "depth_image_metres_per_unit"}) {
    EXPECT_NE(problems.find(key), std::string::npos) << key;
  }
}

namespace {

Eigen::Isometry3d isometry(const RelativePose& pose) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = pose.rotation;
  transform.translation() = pose.translation;
  return transform;
}

RelativePose relative(const Eigen::Isometry3d& transform) {
  RelativePose pose;
  pose.rotation = transform.linear();
  pose.translation = transform.translation();
  pose.metric = true;
  return pose;
}

}  // namespace

TEST(InBodyFrame, GivesTheBodiesRelativePoseAndCarriesTheCovariance) {
  // A camera 0.3 m ahead, 0.1 m left and 1.2 m up on the body, pitched down 10 degrees.
  CameraMount mount;
  mount.x = 0.3;
  mount.y = 0.1;
  mount.z = 1.2;
  mount.pitch = 10.0 / kRadiansToDegrees;
  const Eigen::Isometry3d m = mount.toPose().toIsometry();
  const Eigen::Isometry3d query_body = planarPose(1.0, 2.0, 0.3).toIsometry();
  Eigen::Isometry3d match_body = planarPose(1.8, 1.5, -0.4).toIsometry();
  match_body.translate(Eigen::Vector3d(0.0, 0.0, 0.05));
  RelativePose in_camera = relative((query_body * m).inverse() * match_body * m);
  Eigen::Matrix<double, 6, 6> spread = Eigen::Matrix<double, 6, 6>::Random();
  in_camera.covariance = 1e-4 * spread * spread.transpose();

  const RelativePose in_body = inBodyFrame(in_camera, mount.toPose());
  const Eigen::Isometry3d truth = query_body.inverse() * match_body;
  EXPECT_TRUE(in_body.metric);
  EXPECT_LT((in_body.translation - truth.translation()).norm(), 1e-12);
  EXPECT_LT((in_body.rotation - truth.linear()).norm(), 1e-12);

  // The covariance follows a small step of the camera-frame pose (translation added, rotation
  // applied on the left) to the step it makes in the body frame.
  Eigen::Matrix<double, 6, 6> jacobian;
  for (int axis = 0; axis < 6; ++axis) {
    constexpr double kStep = 1e-6;
    RelativePose moved = in_camera;
    if (axis < 3) {
      moved.translation[axis] += kStep;
    } else {
      moved.rotation = Eigen::AngleAxisd(kStep, Eigen::Vector3d::Unit(axis - 3)) * moved.rotation;
    }
    const RelativePose moved_body = inBodyFrame(moved, mount.toPose());
    const Eigen::AngleAxisd turn(moved_body.rotation * in_body.rotation.transpose());
    jacobian.col(axis).head<3>() = (moved_body.translation - in_body.translation) / kStep;
    jacobian.col(axis).tail<3>() = turn.angle() * turn.axis() / kStep;
  }
  const Eigen::Matrix<double, 6, 6> expected =
      jacobian * in_camera.covariance * jacobian.transpose();
  EXPECT_LT((in_body.covariance - expected).norm(), 1e-6 * expected.norm());

  // The mount's inverse takes it back.
  const RelativePose back = inBodyFrame(in_body, Pose::fromIsometry(m.inverse()));
  EXPECT_LT((isometry(back).matrix() - isometry(in_camera).matrix()).norm(), 1e-12);
  EXPECT_LT((back.covariance - in_camera.covariance).norm(), 1e-12);
}

// Two robots whose cameras sit differently (a loop between robots): each end of the camera-frame
// pose is turned by its own robot's mount, and the covariance follows.
TEST(InBodyFrames, EachEndTakesItsOwnRobotsMount) {
  CameraMount query_mount;  // Robot a: the camera 1.2 m up, looking ahead.
  query_mount.z = 1.2;
  CameraMount match_mount;  // Robot b: 0.3 m ahead of its base and pitched down 10 degrees.
  match_mount.x = 0.3;
  match_mount.z = 0.9;
  match_mount.roll = -(90.0 + 10.0) / kRadiansToDegrees;  // The optical axis 10 degrees down.
  const Eigen::Isometry3d mq = query_mount.toPose().toIsometry();
  const Eigen::Isometry3d mm = match_mount.toPose().toIsometry();
  const Eigen::Isometry3d query_body = planarPose(1.0, 2.0, 0.3).toIsometry();
  const Eigen::Isometry3d match_body = planarPose(1.8, 1.5, -0.4).toIsometry();
  RelativePose in_cameras = relative((query_body * mq).inverse() * match_body * mm);
  Eigen::Matrix<double, 6, 6> spread = Eigen::Matrix<double, 6, 6>::Random();
  in_cameras.covariance = 1e-4 * spread * spread.transpose();

  const RelativePose in_bodies =
      inBodyFrames(in_cameras, query_mount.toPose(), match_mount.toPose());
  const Eigen::Isometry3d truth = query_body.inverse() * match_body;
  EXPECT_LT((in_bodies.translation - truth.translation()).norm(), 1e-12);
  EXPECT_LT((in_bodies.rotation - truth.linear()).norm(), 1e-12);
  // The query's mount at both ends (what a single mount gives) is off by the difference.
  const RelativePose one_mount = inBodyFrame(in_cameras, query_mount.toPose());
  EXPECT_GT((one_mount.translation - truth.translation()).norm(), 0.2);

  Eigen::Matrix<double, 6, 6> jacobian;
  for (int axis = 0; axis < 6; ++axis) {
    constexpr double kStep = 1e-6;
    RelativePose moved = in_cameras;
    if (axis < 3) {
      moved.translation[axis] += kStep;
    } else {
      moved.rotation = Eigen::AngleAxisd(kStep, Eigen::Vector3d::Unit(axis - 3)) * moved.rotation;
    }
    const RelativePose moved_bodies =
        inBodyFrames(moved, query_mount.toPose(), match_mount.toPose());
    const Eigen::AngleAxisd turn(moved_bodies.rotation * in_bodies.rotation.transpose());
    jacobian.col(axis).head<3>() = (moved_bodies.translation - in_bodies.translation) / kStep;
    jacobian.col(axis).tail<3>() = turn.angle() * turn.axis() / kStep;
  }
  const Eigen::Matrix<double, 6, 6> expected =
      jacobian * in_cameras.covariance * jacobian.transpose();
  EXPECT_LT((in_bodies.covariance - expected).norm(), 1e-6 * expected.norm());
}

TEST(DepthImage, OnlyFiniteReadingsAboveZeroCount) {
  EXPECT_FALSE(hasUsableDepth(cv::Mat()));
  EXPECT_FALSE(hasUsableDepth(cv::Mat::zeros(4, 5, CV_16UC1)));
  cv::Mat millimetres = cv::Mat::zeros(4, 5, CV_16UC1);
  millimetres.at<uint16_t>(2, 3) = 1500;
  EXPECT_TRUE(hasUsableDepth(millimetres));
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(),
                          std::numeric_limits<float>::infinity(), -2.0f, 0.0f}) {
    EXPECT_FALSE(hasUsableDepth(cv::Mat(4, 5, CV_32FC1, cv::Scalar(bad)))) << bad;
  }
  cv::Mat metres(4, 5, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  metres.at<float>(3, 4) = 2.5f;
  EXPECT_TRUE(hasUsableDepth(metres));
  EXPECT_FALSE(hasUsableDepth(cv::Mat(4, 5, CV_8UC1, cv::Scalar(7)))) << "not a depth type";
}

TEST(PoseJacobian, DifferentiatesTheChosenColumnsInOrder) {
  // r(p) = (2 p0 + p1^2, 3 p2, sin(p3)): at zero dr/dp = [[2, 0, 0, 0], [0, 0, 3, 0], [0, 0, 0,
  // 1]].
  const auto residuals = [](const Eigen::VectorXd& p) {
    Eigen::VectorXd r(3);
    r << 2.0 * p(0) + p(1) * p(1), 3.0 * p(2), std::sin(p(3));
    return r;
  };
  const Eigen::MatrixXd all = poseJacobian(residuals, 4, allColumns(4));
  ASSERT_EQ(all.rows(), 3);
  ASSERT_EQ(all.cols(), 4);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(3, 4);
  expected(0, 0) = 2.0;
  expected(1, 2) = 3.0;
  expected(2, 3) = 1.0;
  EXPECT_LT((all - expected).cwiseAbs().maxCoeff(), 1e-6);
  // The last two only (a rotation-only refinement holds the others).
  const Eigen::MatrixXd some = poseJacobian(residuals, 4, {2, 3});
  ASSERT_EQ(some.cols(), 2);
  EXPECT_NEAR(some(1, 0), 3.0, 1e-6);
  EXPECT_NEAR(some(2, 1), 1.0, 1e-6);
  EXPECT_NEAR(some(0, 0), 0.0, 1e-6);
}
