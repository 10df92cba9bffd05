#include <cmath>

#include <gtest/gtest.h>

#include "landmark_loop_closure/sim/sequence.h"

using namespace landmark_loop_closure::sim;

TEST(CorridorWorld, CentreLineIsClosedAndContinuous) {
  const CorridorWorld world;
  const Pose2D start = world.poseAt(0.0, 0.0);
  const Pose2D end = world.poseAt(world.lapLength() - 1e-9, 0.0);
  EXPECT_NEAR(start.x, end.x, 1e-6);
  EXPECT_NEAR(start.y, end.y, 1e-6);
  for (double s = 0.0; s < world.lapLength(); s += 0.05) {
    const Pose2D a = world.poseAt(s, 0.0);
    const Pose2D b = world.poseAt(s + 0.05, 0.0);
    EXPECT_NEAR(std::hypot(b.x - a.x, b.y - a.y), 0.05, 2e-3) << "at s = " << s;
  }
}

TEST(CorridorWorld, RendersTexturedImagesThatDependOnPlace) {
  const CorridorWorld world;
  const CameraModel camera;
  const cv::Mat a = world.render(world.poseAt(5.0, 0.0), camera, Lighting{}, 1);
  const cv::Mat b = world.render(world.poseAt(30.0, 0.0), camera, Lighting{}, 1);
  ASSERT_EQ(a.size(), cv::Size(camera.width, camera.height));
  ASSERT_EQ(a.type(), CV_8UC1);
  cv::Scalar mean, stddev;
  cv::meanStdDev(a, mean, stddev);
  EXPECT_GT(stddev[0], 20.0);  // Textured, not blank.
  EXPECT_GT(cv::norm(a, b, cv::NORM_L1) / a.total(), 10.0);
}

TEST(SequenceGenerator, OdometryDriftsAwayFromTruth) {
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 1.0;
  SequenceGenerator sequence(world, CameraModel{}, options);
  SequenceFrame frame;
  SequenceFrame first;
  ASSERT_TRUE(sequence.next(&first, false));
  EXPECT_DOUBLE_EQ(first.odom.x, first.truth.x);
  while (sequence.next(&frame, false)) {
  }
  EXPECT_EQ(frame.index + 1, sequence.size());
  const double drift = std::hypot(frame.odom.x - frame.truth.x, frame.odom.y - frame.truth.y);
  EXPECT_GT(drift, 0.5);
  EXPECT_LT(drift, 10.0);
}
