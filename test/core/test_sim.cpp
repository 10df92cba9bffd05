#include <cmath>

#include <gtest/gtest.h>

#include "landmark_loop_closure/geometry/pose.h"
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

TEST(CorridorWorld, BaysLookAlikeOneBayApart) {
  // Facing the left wall on the first straight: 4 m further on, the aliasing world shows the
  // same door, lockers and notice board (only the room-number plate differs); the ordinary world
  // shows another stretch of wall.
  const CameraModel camera;
  const auto difference = [&camera](const CorridorWorld& world, double s, double step) {
    Pose2D a = world.poseAt(s, 0.0);
    Pose2D b = world.poseAt(s + step, 0.0);
    a.yaw += M_PI / 2.0;
    b.yaw += M_PI / 2.0;
    const cv::Mat first = world.render(a, camera, Lighting{1.0, 0.0, 0.0}, 1);
    const cv::Mat second = world.render(b, camera, Lighting{1.0, 0.0, 0.0}, 1);
    return cv::norm(first, second, cv::NORM_L1) / static_cast<double>(first.total());
  };
  CorridorWorld::Options options;
  options.bay_length = 4.0;
  const CorridorWorld bays(options);
  const CorridorWorld varied;
  // Wall coordinates start where the wall's texture does, so one bay along the centre line is
  // one bay along the inner wall only on a straight: 4 m, on the first straight (12 m long).
  EXPECT_LT(difference(bays, 2.0, 4.0), 8.0);
  EXPECT_GT(difference(bays, 2.0, 2.0), 2.0 * difference(bays, 2.0, 4.0))
      << "half a bay on, another part of the bay";
  EXPECT_GT(difference(varied, 2.0, 4.0), 3.0 * difference(bays, 2.0, 4.0));
}

TEST(CorridorWorld, DepthImageGivesDistancesAlongTheOpticalAxis) {
  const CorridorWorld world;
  const CameraModel camera;
  // On a straight stretch, 0.5 m left of the centre line, facing the left wall: 1.5 - 0.5 m away.
  Pose2D pose = world.poseAt(8.0, 0.5);
  pose.yaw += M_PI / 2.0;
  const cv::Mat depth = world.renderDepth(pose, camera);
  ASSERT_EQ(depth.type(), CV_32FC1);
  ASSERT_EQ(depth.size(), cv::Size(camera.width, camera.height));
  const int cx = camera.width / 2;
  const int cy = camera.height / 2;
  EXPECT_NEAR(depth.at<float>(cy, cx), 1.0, 1e-3);
  // A flat wall faces the camera: the same optical depth across the row (no fish-eye bend).
  EXPECT_NEAR(depth.at<float>(cy, cx - 60), 1.0, 1e-3);
  EXPECT_NEAR(depth.at<float>(cy, cx + 60), 1.0, 1e-3);
  // Looking along the corridor: the floor at row r lies at height * f / (r - cy); the ceiling
  // has no depth.
  const Pose2D along = world.poseAt(8.0, 0.0);
  const cv::Mat corridor = world.renderDepth(along, camera);
  const int floor_row = camera.height - 1;
  const double dy = floor_row - 0.5 * (camera.height - 1);
  EXPECT_NEAR(corridor.at<float>(floor_row, cx), camera.height_m * camera.focal_px / dy, 1e-3);
  EXPECT_EQ(corridor.at<float>(0, cx), 0.0f);
}

// A camera ahead of the base or pitched is rendered ray by ray: level and at the base it gives
// the column renderer's image; 0.3 m ahead it sees what a camera at the base sees from 0.3 m on;
// looking 30 degrees down, the centre row's ray meets the floor where the pitch says, and
// camera_mount's roll of -100 degrees is a camera looking 10 degrees down.
TEST(CorridorWorld, AMountedCameraSeesWhatItsMountSays) {
  const CorridorWorld world;
  const Lighting quiet{1.0, 0.0, 0.0};
  const Pose2D pose = world.poseAt(8.0, 0.0);
  CameraModel level;
  CameraModel nearly_level = level;
  nearly_level.pitch_rad = 1e-12;
  cv::Mat difference;
  cv::absdiff(world.render(pose, level, quiet, 1), world.render(pose, nearly_level, quiet, 1),
              difference);
  EXPECT_LT(cv::mean(difference)[0], 1.0);

  CameraModel ahead = level;
  ahead.forward_m = 0.3;
  Pose2D moved = pose;
  moved.x += 0.3 * std::cos(pose.yaw);
  moved.y += 0.3 * std::sin(pose.yaw);
  cv::absdiff(world.render(pose, ahead, quiet, 1), world.render(moved, level, quiet, 1),
              difference);
  EXPECT_LT(cv::mean(difference)[0], 1.0);

  CameraModel down = level;
  down.pitch_rad = 30.0 * M_PI / 180.0;
  const cv::Mat depth = world.renderDepth(pose, down);
  const int cx = (down.width - 1) / 2, cy = (down.height - 1) / 2;
  // The ray of row cy, optical depth 1: it falls by sin(pitch) - up cos(pitch) per unit.
  const double up = (0.5 * (down.height - 1) - cy) / down.focal_px;
  EXPECT_NEAR(depth.at<float>(cy, cx),
              down.height_m / (std::sin(down.pitch_rad) - up * std::cos(down.pitch_rad)), 1e-3);
  landmark_loop_closure::CameraMount mount;
  const double ten_degrees = 10.0 * M_PI / 180.0;
  mount.roll = -M_PI / 2.0 - ten_degrees;
  const Eigen::Vector3d optical_axis = mount.toPose().orientation * Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(optical_axis.isApprox(
      Eigen::Vector3d(std::cos(ten_degrees), 0.0, -std::sin(ten_degrees)), 1e-12))
      << optical_axis.transpose();
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
