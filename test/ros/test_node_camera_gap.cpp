// The running node across a camera that falls silent while the robot drives on (issue 80 point
// 4): 12 s without images over 8 m of continuous 20 Hz odometry keeps the session, and the
// diagnostics report the session the keyframes carry; odometry that really re-initialises (one
// of its own steps jumps) still starts a new session after jump_reanchor_frames frames.
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <ros/ros.h>

#include "node_harness.h"

using namespace landmark_loop_closure;

namespace {

constexpr double kStart = 1000.0;
constexpr double kSpeed = 8.0 / 12.0;  // m/s: 8 m in the 12 s gap.
constexpr double kGapFrom = kStart + 4.0;
constexpr double kGapTo = kGapFrom + 12.0;
constexpr double kResetAt = kGapTo + 4.0;
constexpr double kEnd = kResetAt + 5.0;
constexpr double kResetBack = 20.0;  // The odometry starts again 20 m back.

sim::Pose2D odometryAt(double stamp) {
  const double x = kSpeed * (stamp - kStart);
  return {stamp >= kResetAt ? x - kResetBack : x, 0.0, 0.0};
}

void spinFor(double seconds) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.02).sleep();
  }
}

}  // namespace

TEST(LoopClosureNode, ACameraGapWhileDrivingKeepsTheSessionAndAResetStartsOne) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  std::mt19937 random(7);
  std::uniform_int_distribution<int> grey(0, 255);
  const sim::CameraModel camera;
  // Odometry at 20 Hz throughout, images at 10 Hz except in the gap; published 3x real time,
  // paced as a robot's messages are (a burst would overflow the node's odometry queue).
  ros::WallRate rate(60.0);
  for (int step = 0; kStart + 0.05 * step <= kEnd; ++step) {
    const double stamp = kStart + 0.05 * step;
    const bool image = step % 2 == 0 && !(stamp > kGapFrom && stamp < kGapTo);
    if (image) {
      cv::Mat pixels(camera.height, camera.width, CV_8UC1);
      for (int k = 0; k < pixels.rows * pixels.cols; ++k) pixels.data[k] = grey(random);
      harness.publish(stamp, odometryAt(stamp), pixels);
    } else {
      harness.publishOdometry(stamp, odometryAt(stamp));
    }
    ros::spinOnce();
    rate.sleep();
    if (std::abs(stamp - (kGapTo + 2.0)) < 0.025) {
      spinFor(2.0);  // Diagnostics after the gap, before the reset.
      EXPECT_EQ(harness.diagnostic("session"), "0") << "the gap started a session";
    }
  }
  spinFor(3.0);
  std::set<uint32_t> before_reset;
  std::set<uint32_t> after_reset;
  size_t after_gap = 0;
  for (const Keyframe& keyframe : harness.publishedKeyframes()) {
    const double stamp = keyframe.header.stamp.toSec();
    (stamp < kResetAt ? before_reset : after_reset).insert(keyframe.session);
    after_gap += stamp >= kGapTo && stamp < kResetAt;
  }
  EXPECT_GT(after_gap, 5u) << "keyframes go on after the gap";
  EXPECT_EQ(before_reset, std::set<uint32_t>{0}) << "a camera gap is no odometry reset";
  EXPECT_EQ(harness.loggedCount("after a camera gap"), 1u);
  EXPECT_EQ(after_reset.count(1u), 1u) << "a real reset starts a session";
  EXPECT_EQ(harness.diagnostic("session"), "1") << "diagnostics report the keyframes' session";
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_camera_gap");
  return RUN_ALL_TESTS();
}
