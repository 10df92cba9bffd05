// use_depth with a depth topic that is advertised but never published (a driver that advertises
// and stalls): one bounded wait, one warning naming the topic, and keyframes go on without depth
// at their normal speed; once depth images come they are used again.
#include <string>

#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

// Handles what arrives for `seconds`, diagnostics included (published once a second).
void spinFor(double seconds) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
}

}  // namespace

TEST(LoopClosureNode, ASilentDepthPublisherCostsOneWaitAndOneWarning) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  ASSERT_TRUE(harness.depthWanted()) << "the launch file sets use_depth";
  // The harness advertises the depth topic and publishes nothing on it.
  harness.publishCorridor(0, 300);
  harness.waitUntilQuiet();
  spinFor(2.5);
  const size_t keyframes = harness.keyframes().size();
  EXPECT_GT(keyframes, 30u);
  EXPECT_EQ(harness.loggedCount("No depth image came on /camera/depth/image_raw"), 1u);
  EXPECT_EQ(harness.diagnostic("depth stream"), "silent: advertised, nothing published");
  EXPECT_EQ(harness.diagnostic("keyframes with depth"), "0");
  EXPECT_GE(std::stoul(harness.diagnostic("keyframes without depth")), keyframes);
  EXPECT_TRUE(harness.summarySaid("no depth image on /camera/depth/image_raw"));
  // Each keyframe used to wait 0.2 s for the depth that never came.
  EXPECT_LT(std::stod(harness.diagnostic("last keyframe processing (ms)")), 180.0)
      << "keyframes still wait for the silent depth topic";

  // Depth images come: used again, and said.
  const CorridorWorld world;
  SequenceGenerator sequence(world, CameraModel{}, SequenceOptions{});
  ros::WallRate rate(test_support::kPublishRateHz);
  SequenceFrame frame;
  while (ros::ok() && sequence.next(&frame) && frame.index < 420) {
    if (frame.index < 300) continue;
    harness.publish(frame.stamp, frame.odom, frame.image);
    harness.publishDepth(frame.stamp, world.renderDepth(frame.truth, {}));
    ros::spinOnce();
    rate.sleep();
  }
  harness.waitUntilQuiet();
  spinFor(2.5);
  EXPECT_GT(harness.keyframes().size(), keyframes);
  EXPECT_NE(harness.diagnostic("keyframes with depth"), "0");
  EXPECT_EQ(harness.diagnostic("depth stream"), "ok");
  EXPECT_EQ(harness.loggedCount("Depth images arrive on /camera/depth/image_raw again"), 1u);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_depth_silent");
  return RUN_ALL_TESTS();
}
