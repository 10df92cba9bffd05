// The running node, fed two laps of the corridor, publishes loops whose keyframes are truly at
// the same place, with ids and stamps that agree with its keyframes topic.
#include <cstdio>
#include <map>
#include <vector>

#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

TEST(LoopClosureNode, RevisitPublishesLoopsThatMatchTheTruth) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 2.0;
  options.start_stamp = 1700000000.123456789;  // Epoch-scale stamps, as on a real robot.
  SequenceGenerator sequence(world, CameraModel{}, options);
  std::map<ros::Time, Pose2D> truth;
  ros::WallRate rate(test_support::kPublishRateHz);
  SequenceFrame frame;
  while (ros::ok() && sequence.next(&frame)) {
    truth[ros::Time(frame.stamp)] = frame.truth;
    harness.publish(frame.stamp, frame.odom, frame.image);
    ros::spinOnce();
    rate.sleep();
  }
  harness.waitUntilQuiet();

  EXPECT_GT(harness.keyframes().size(), 400u);
  double min_score = 0.0;
  ASSERT_TRUE(ros::param::get("/loop_closure/acceptance/min_score", min_score));
  bool publish_scale_free_pose = false;
  ros::param::get("/loop_closure/verification/publish_scale_free_pose", publish_scale_free_pose);
  ASSERT_GE(harness.loops().size(), 5u);
  std::vector<double> turn_errors_deg;
  for (const LoopClosure& loop : harness.loops()) {
    SCOPED_TRACE("loop " + std::to_string(loop.query_id) + " -> " + std::to_string(loop.match_id));
    ASSERT_EQ(harness.keyframes().count(loop.query_id), 1u);
    ASSERT_EQ(harness.keyframes().count(loop.match_id), 1u);
    EXPECT_EQ(harness.keyframes().at(loop.query_id), loop.query_stamp);
    EXPECT_EQ(harness.keyframes().at(loop.match_id), loop.match_stamp);
    // Stamps are the images' own, to the nanosecond, so a backend can look them up exactly.
    ASSERT_EQ(truth.count(loop.query_stamp), 1u);
    ASSERT_EQ(truth.count(loop.match_stamp), 1u);
    const Pose2D& query = truth.at(loop.query_stamp);
    const Pose2D& match = truth.at(loop.match_stamp);
    EXPECT_LT(std::hypot(query.x - match.x, query.y - match.y), 2.5);
    EXPECT_GT(loop.query_id, loop.match_id);
    EXPECT_GE(loop.score, min_score);
    // camera_info came with the images, so every loop passed the geometric check.
    EXPECT_TRUE(loop.verified);
    EXPECT_GE(loop.inliers, 30u);
    // The corridor's texture lies in one band at mid-height, so most of its poses are ambiguous
    // and go out without one.
    if (loop.has_relative_pose) {
      EXPECT_TRUE(publish_scale_free_pose);
      const double true_turn =
          std::abs(std::remainder(match.yaw - query.yaw, 2.0 * M_PI)) * 180.0 / M_PI;
      const double estimated_turn =
          2.0 * std::acos(std::min(1.0, std::abs(loop.relative_pose.pose.orientation.w))) * 180.0 /
          M_PI;
      turn_errors_deg.push_back(std::abs(estimated_turn - true_turn));
    }
    EXPECT_EQ(loop.header.frame_id, "odom");
  }
  // Two views alone leave about one scale-free pose in four in a wrong minimum a few degrees away
  // (README, "Geometric verification"), so this checks that the message carries the estimate
  // (a wrong convention would miss every turn), not that each two-view pose is right; accuracy is
  // asserted on generated pairs in the core tests.
  std::size_t within_two_degrees = 0;
  for (const double error : turn_errors_deg) within_two_degrees += error < 2.0 ? 1 : 0;
  std::printf("%zu scale-free poses published, %zu within 2 deg of the true turn\n",
              turn_errors_deg.size(), within_two_degrees);
  EXPECT_GE(2 * within_two_degrees, turn_errors_deg.size());
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_revisit");
  return RUN_ALL_TESTS();
}
