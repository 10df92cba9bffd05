// The running node, fed a one-way route with bad frames mixed in (unsupported encoding, NaN pose,
// a stamp 10 s back, the clock set back for good, black frames), publishes no loop, drops every
// bad frame without output, keeps working after them and counts them in its diagnostics.
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

TEST(LoopClosureNode, OneWayRouteWithBadInputPublishesNoLoopAndSurvives) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 0.9;
  SequenceGenerator sequence(world, CameraModel{}, options);
  std::set<ros::Time> bad_stamps;
  // From frame 350 on the sender's clock is 30.03 s behind (set back for good; off the 0.05 s grid
  // so no later stamp equals an earlier one): every frame is "not after the last keyframe" until
  // time_jump_frames (30) of them make a time jump and the next starts a new timeline.
  constexpr int kClockSetBackAt = 350;
  constexpr double kClockSetBack = 30.03;
  std::set<ros::Time> after_bad_input;
  ros::WallRate rate(test_support::kPublishRateHz);
  SequenceFrame frame;
  // First of all, a frame whose driver never set its stamp: refused, it cannot be placed in time.
  ASSERT_TRUE(sequence.next(&frame));
  harness.publish(0.0, frame.odom, frame.image);
  bad_stamps.insert(ros::Time());
  ros::spinOnce();
  rate.sleep();
  while (ros::ok() && sequence.next(&frame)) {
    if (frame.index >= kClockSetBackAt) frame.stamp -= kClockSetBack;
    if (frame.index >= kClockSetBackAt && frame.index < kClockSetBackAt + 29) {
      bad_stamps.insert(ros::Time(frame.stamp));  // Refused, the 30th starts the new timeline.
    }
    if (frame.index > 440) after_bad_input.insert(ros::Time(frame.stamp));
    if (frame.index >= 400 && frame.index < 440) {  // Lens cap on: black frames, moving on.
      harness.publish(frame.stamp, frame.odom, cv::Mat::zeros(frame.image.size(), CV_8UC1));
      bad_stamps.insert(ros::Time(frame.stamp));
    } else {
      harness.publish(frame.stamp, frame.odom, frame.image);
    }
    const double between = frame.stamp + 0.5 / options.rate;  // Its own stamp, after this frame.
    if (frame.index == 100 || frame.index == 101) {           // Float image: unsupported encoding.
      harness.publish(between, frame.odom, frame.image, "32FC1");
      bad_stamps.insert(ros::Time(between));
    } else if (frame.index == 200 || frame.index == 201) {  // Odometry with NaN.
      harness.publish(between, frame.odom, frame.image, "mono8", true);
      bad_stamps.insert(ros::Time(between));
    } else if (frame.index == 300) {  // Back in time by 10 s (a bag restarted).
      const double old = frame.stamp - 10.0;
      harness.publish(old, frame.odom, frame.image);
      bad_stamps.insert(ros::Time(old));
    }
    ros::spinOnce();
    rate.sleep();
  }
  harness.waitUntilQuiet(3.0);

  EXPECT_TRUE(harness.loops().empty()) << harness.loops().size() << " loops on a one-way route";
  EXPECT_GT(harness.keyframes().size(), 150u);
  size_t keyframes_after = 0;
  for (const auto& [id, stamp] : harness.keyframes()) {
    EXPECT_EQ(bad_stamps.count(stamp), 0u)
        << "keyframe " << id << " came from a bad frame, stamped " << stamp;
    keyframes_after += after_bad_input.count(stamp);
  }
  EXPECT_GT(keyframes_after, 20u) << "the node stopped after the bad input";
  EXPECT_EQ(harness.diagnostic("time jumps (new timelines)"), "1");
  EXPECT_TRUE(harness.summarySaid("Time jumped back (30 frames in a row"));
  EXPECT_NE(harness.diagnostic("rejected: unsupported_image_type"), "");
  EXPECT_NE(harness.diagnostic("rejected: non_finite_pose"), "");
  EXPECT_NE(harness.diagnostic("rejected: unset_stamp"), "");
  EXPECT_NE(harness.diagnostic("rejected: no_texture"), "");
  EXPECT_EQ(harness.diagnostic("camera_info"), "usable");

  // Bad calibrations one after another, within one warning period: each cause is said in its own
  // WARN (one throttle per cause), named rightly, and turns the geometric check off.
  const auto feed = [&](int count) {
    for (int i = 1; i <= count; ++i) {
      frame.stamp += 0.1;
      harness.publish(frame.stamp, frame.odom, frame.image);
      ros::spinOnce();
      rate.sleep();
    }
  };
  const auto waitForCameraInfo = [&](const std::string& prefix) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(5.0);
    while (harness.diagnostic("camera_info").rfind(prefix, 0) != 0 && ros::WallTime::now() < end) {
      ros::spinOnce();
      ros::WallDuration(0.05).sleep();
    }
    return harness.diagnostic("camera_info");
  };
  const sensor_msgs::CameraInfo::_K_type good = test_support::NodeHarness::calibratedK();
  struct BadCalibration {
    sensor_msgs::CameraInfo::_K_type k;
    std::string cause;
    std::string diagnostic;
  };
  sensor_msgs::CameraInfo::_K_type zeros{};
  sensor_msgs::CameraInfo::_K_type nan_k = good;
  nan_k[5] = std::numeric_limits<double>::quiet_NaN();
  sensor_msgs::CameraInfo::_K_type negative = good;
  negative[0] = -good[0];
  sensor_msgs::CameraInfo::_K_type tiny = good;
  tiny[0] = tiny[4] = 1e-12;
  const std::vector<BadCalibration> bad_calibrations = {
      {zeros, "(no_calibration): K is all zeros", "invalid: K is all zeros"},
      {nan_k, "(non_finite): K holds a non-finite value", "invalid: K holds a non-finite"},
      {negative, "(focal_not_positive): focal lengths fx -", "invalid: focal lengths fx -"},
      {tiny, "(focal_implausible): focal lengths fx 1e-12", "invalid: focal lengths fx 1e-12"},
  };
  for (const BadCalibration& bad : bad_calibrations) {
    harness.setCameraMatrix(bad.k);
    feed(10);
    EXPECT_TRUE(harness.waitForLog("camera_info not used, the geometric check is off " + bad.cause))
        << bad.cause;
    EXPECT_EQ(waitForCameraInfo(bad.diagnostic).rfind(bad.diagnostic, 0), 0u)
        << harness.diagnostic("camera_info");
  }
  EXPECT_EQ(harness.loggedCount("(no_calibration)"), 1u) << "one WARN per cause and period";
  EXPECT_TRUE(harness.summarySaid("geometric check off: camera_info invalid"));

  // A good calibration again, then dropped images of other shapes: only accepted images judge it.
  harness.setCameraMatrix(good);
  feed(10);
  EXPECT_EQ(waitForCameraInfo("usable"), "usable");
  frame.stamp += 0.1;
  harness.publish(frame.stamp, frame.odom, cv::Mat(1, 1, CV_8UC1, cv::Scalar(128)));
  frame.stamp += 0.1;
  cv::Mat tall(10000, 10, CV_8UC1);
  cv::randu(tall, 0, 255);
  harness.publish(frame.stamp, frame.odom, tall);
  EXPECT_TRUE(harness.waitForLog("image 1x1 is smaller than the minimum side"));
  ros::WallDuration(2.5).sleep();  // More than one diagnostics period.
  ros::spinOnce();
  EXPECT_EQ(harness.diagnostic("camera_info"), "usable") << "a dropped image changed it";
  EXPECT_EQ(harness.loggedCount("(aspect_ratio)"), 0u);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_bad_input");
  return RUN_ALL_TESTS();
}
