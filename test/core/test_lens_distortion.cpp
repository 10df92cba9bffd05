// Lens distortion: keypoints corrected by camera_info's model (plumb_bob, rational_polynomial,
// equidistant) before the geometric check, and what ignoring a strong lens costs.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/sim/corridor_world.h"
#include "textured_room.h"

using namespace landmark_loop_closure;

namespace {

const sim::CameraModel kCamera;
const cv::Size kImageSize(kCamera.width, kCamera.height);

CameraIntrinsics lens(LensDistortion model, std::vector<double> coefficients) {
  CameraIntrinsics k = kCamera.intrinsics();
  k.distortion = model;
  k.distortion_name = model == LensDistortion::kEquidistant ? "equidistant" : "plumb_bob";
  k.coefficients = std::move(coefficients);
  return k;
}

// A barrel lens like a wide-angle webcam's: k1 -0.3.
CameraIntrinsics barrel() { return lens(LensDistortion::kPlumbBob, {-0.3, 0.08, 0.0, 0.0, 0.0}); }

std::vector<cv::Point2f> grid() {
  std::vector<cv::Point2f> points;
  for (int y = 10; y < kImageSize.height; y += 40) {
    for (int x = 10; x < kImageSize.width; x += 40) points.emplace_back(x, y);
  }
  return points;
}

double largestDistance(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  double largest = 0.0;
  for (size_t i = 0; i < a.size(); ++i) largest = std::max(largest, cv::norm(a[i] - b[i]));
  return largest;
}

double medianOf(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

TEST(LensDistortion, IdealPixelsUndoEachModel) {
  const std::vector<CameraIntrinsics> lenses = {
      barrel(),
      lens(LensDistortion::kRationalPolynomial, {-0.25, 0.05, 0.001, -0.001, 0.0, 0.01, 0.0, 0.0}),
      lens(LensDistortion::kEquidistant, {0.05, -0.02, 0.01, 0.0})};
  for (const CameraIntrinsics& k : lenses) {
    SCOPED_TRACE(k.distortion_name);
    ASSERT_TRUE(k.valid()) << k.problem();
    ASSERT_TRUE(k.distorted());
    const std::vector<cv::Point2f> ideal = grid();
    const std::vector<cv::Point2f> seen = k.imagePixels(ideal);
    EXPECT_GT(largestDistance(ideal, seen), 3.0) << "the lens moves the corners";
    EXPECT_LT(largestDistance(k.idealPixels(seen), ideal), 0.01);
  }
  // A pinhole changes nothing.
  const CameraIntrinsics pinhole = kCamera.intrinsics();
  EXPECT_FALSE(pinhole.distorted());
  EXPECT_EQ(largestDistance(pinhole.idealPixels(grid()), grid()), 0.0);
}

TEST(LensDistortion, TheModelScalesWithTheImage) {
  const CameraIntrinsics full = barrel();
  const CameraIntrinsics half = full.scaledTo(cv::Size(160, 120));
  EXPECT_TRUE(half.distorted());
  // The same keypoint at half size lands at (half) the same ideal pixel (pixel centres scale).
  const std::vector<cv::Point2f> seen = {{20.0f, 15.0f}, {300.0f, 220.0f}};
  std::vector<cv::Point2f> seen_half;
  for (const cv::Point2f& p : seen)
    seen_half.emplace_back((p.x + 0.5f) / 2 - 0.5f, (p.y + 0.5f) / 2 - 0.5f);
  const std::vector<cv::Point2f> ideal = full.idealPixels(seen);
  const std::vector<cv::Point2f> ideal_half = half.idealPixels(seen_half);
  for (size_t i = 0; i < seen.size(); ++i) {
    EXPECT_NEAR((ideal[i].x + 0.5f) / 2 - 0.5f, ideal_half[i].x, 1e-3);
    EXPECT_NEAR((ideal[i].y + 0.5f) / 2 - 0.5f, ideal_half[i].y, 1e-3);
  }
}

TEST(LensDistortion, AnUnusableLensModelHasItsOwnCause) {
  CameraIntrinsics unknown = barrel();
  unknown.distortion = lensDistortionNamed("kannala_brandt_9");
  unknown.distortion_name = "kannala_brandt_9";
  ASSERT_TRUE(unknown.check());
  EXPECT_EQ(unknown.check()->cause, "distortion_model");
  EXPECT_NE(unknown.problem().find("\"kannala_brandt_9\""), std::string::npos) << unknown.problem();

  CameraIntrinsics short_d = barrel();
  short_d.coefficients = {-0.3, 0.1};
  ASSERT_TRUE(short_d.check());
  EXPECT_EQ(short_d.check()->cause, "distortion_coefficients");
  EXPECT_NE(short_d.problem().find("D has 2 values: plumb_bob needs 5"), std::string::npos)
      << short_d.problem();

  CameraIntrinsics nan_d = barrel();
  nan_d.coefficients[1] = std::nan("");
  ASSERT_TRUE(nan_d.check());
  EXPECT_EQ(nan_d.check()->cause, "distortion_coefficients");

  CameraIntrinsics four = barrel();  // plumb_bob without k3 is complete too.
  four.coefficients.resize(4);
  EXPECT_TRUE(four.valid()) << four.problem();
  EXPECT_EQ(lensDistortionNamed(""), LensDistortion::kNone);
  EXPECT_EQ(lensDistortionNamed("rational_polynomial"), LensDistortion::kRationalPolynomial);
}

// Keypoints of rendered pinhole pairs moved where a k1 = -0.3 lens would show them: the check on
// corrected keypoints finds the true rotation as on the pinhole pairs; on the keypoints as seen,
// a pinhole model is wrong by far more.
TEST(LensDistortion, CorrectedKeypointsGiveThePinholeAccuracy) {
  const test::TexturedRoom room;
  const GeometricVerifier verifier(VerificationOptions{});
  const CameraIntrinsics camera = barrel();
  cv::RNG rng(11);
  std::vector<double> corrected_errors;
  std::vector<double> ignored_errors;
  const auto rotation_error = [](const VerificationResult& result, const Eigen::Isometry3d& truth) {
    return Eigen::AngleAxisd(result.pose.rotation * truth.linear().transpose()).angle() * 180.0 /
           M_PI;
  };
  for (int pair = 0; pair < 30; ++pair) {
    const double x = rng.uniform(-1.5, 1.5);
    const double y = rng.uniform(-1.0, 1.0);
    const double yaw = rng.uniform(-M_PI, M_PI);
    const Eigen::Isometry3d match = test::cameraPose(x, y, 1.3, yaw);
    const Eigen::Isometry3d query = test::cameraPose(
        x + rng.uniform(-0.6, 0.6), y + rng.uniform(-0.6, 0.6), 1.3, yaw + rng.uniform(-0.2, 0.2));
    LocalFeatures seen_query = verifier.extract(room.render(query, kCamera.focal_px, kImageSize));
    LocalFeatures seen_match = verifier.extract(room.render(match, kCamera.focal_px, kImageSize));
    seen_query.points = camera.imagePixels(seen_query.points);
    seen_match.points = camera.imagePixels(seen_match.points);
    LocalFeatures corrected_query = seen_query;
    LocalFeatures corrected_match = seen_match;
    corrected_query.points = camera.idealPixels(seen_query.points);
    corrected_match.points = camera.idealPixels(seen_match.points);
    const Eigen::Isometry3d truth = query.inverse() * match;
    const VerificationResult corrected =
        verifier.verify(corrected_query, corrected_match, kCamera.intrinsics());
    const VerificationResult ignored =
        verifier.verify(seen_query, seen_match, kCamera.intrinsics());
    if (corrected.accepted()) corrected_errors.push_back(rotation_error(corrected, truth));
    if (ignored.accepted()) ignored_errors.push_back(rotation_error(ignored, truth));
  }
  ASSERT_GE(corrected_errors.size(), 10u);
  const double corrected_median = medianOf(corrected_errors);
  std::cout << "rotation error, median: lens corrected " << corrected_median << " deg ("
            << corrected_errors.size() << " poses), ignored "
            << (ignored_errors.empty() ? NAN : medianOf(ignored_errors)) << " deg ("
            << ignored_errors.size() << " poses)\n";
  EXPECT_LT(corrected_median, 1.0);  // The pinhole pairs' own bound.
  // Measured: 0.21 deg corrected, 4.0 deg ignored, the ignoring check accepting more poses.
  ASSERT_GE(ignored_errors.size(), 5u);
  EXPECT_GT(medianOf(ignored_errors), 3.0 * corrected_median);
}
