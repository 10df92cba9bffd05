// The pose graph's side of the messages: loops and keyframes in, verdicts out.
#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "../../src/messages/ros_conversions.h"

using namespace landmark_loop_closure;

namespace {

TEST(PoseGraphMessages, ALoopsQuaternionIsNotNormalisedOnItsWayToTheGraph) {
  LoopClosure message;
  message.relative_pose.pose.position.x = 0.5;
  message.relative_pose.pose.orientation.z = std::sin(0.1);
  message.relative_pose.pose.orientation.w = std::cos(0.1);
  const LoopConstraint turned = graphLoopFromMsg(message).constraint;
  EXPECT_TRUE(isRotation(turned.query_T_match.linear(), 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(turned.query_T_match.rotation()).angle(), 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(turned.query_T_match.translation().x(), 0.5);
  // A default-constructed orientation (all zeros) must not become "no rotation".
  message.relative_pose.pose.orientation = geometry_msgs::Quaternion();
  EXPECT_FALSE(isRotation(graphLoopFromMsg(message).constraint.query_T_match.linear(), 5e-3));
  message.relative_pose.pose.orientation.w = 2.0;
  EXPECT_FALSE(isRotation(graphLoopFromMsg(message).constraint.query_T_match.linear(), 5e-3));
}

TEST(PoseGraphMessages, ALoopsVerdictCarriesItsIdsAndExactStamps) {
  LoopClosure message;
  message.map_id = 9;
  message.match_map_id = 11;  // Another robot's map.
  message.query_id = 40;
  message.match_id = 3;
  message.query_session = message.match_session = 2;
  message.query_stamp = ros::Time(1700000000, 123456789);  // Nanoseconds a double would round.
  message.match_stamp = ros::Time(1699999990, 987654321);
  message.has_relative_pose = message.relative_pose_metric = true;
  message.relative_pose_frame = "camera";
  const GraphLoop loop = graphLoopFromMsg(message);
  EXPECT_EQ(loop.constraint.query_id, 40u);
  EXPECT_EQ(loop.constraint.match_id, 3u);
  EXPECT_EQ(loop.query_session, 2u);
  EXPECT_EQ(loop.matchMap(), 11u);
  EXPECT_TRUE(loop.has_relative_pose && loop.relative_pose_metric);
  EXPECT_EQ(loop.relative_pose_frame, "camera");
  const PoseGraphLoop verdict =
      toPoseGraphLoopMsg({loop, "inconsistent", 4.5, "0.80 m from the graph"}, "map");
  EXPECT_EQ(verdict.header.stamp, message.query_stamp);
  EXPECT_EQ(verdict.query_stamp, message.query_stamp);
  EXPECT_EQ(verdict.match_stamp, message.match_stamp);
  EXPECT_EQ(verdict.header.frame_id, "map");
  EXPECT_EQ(verdict.map_id, 9u);
  EXPECT_EQ(verdict.match_map_id, 11u);
  EXPECT_EQ(verdict.query_id, 40u);
  EXPECT_EQ(verdict.match_id, 3u);
  EXPECT_EQ(verdict.decision, "inconsistent");
  EXPECT_DOUBLE_EQ(verdict.error_sd, 4.5);
  EXPECT_EQ(verdict.detail, "0.80 m from the graph");
}

TEST(PoseGraphMessages, AKeyframeReachesTheGraphWithItsFrameSessionAndExactStamp) {
  const Keyframe message =
      toKeyframeMsg(12, 3, 5, ros::Time(1700000000, 1), planarPose(2.0, 1.0, 0.3), "odom");
  const GraphKeyframe keyframe = graphKeyframeFromMsg(message);
  EXPECT_EQ(keyframe.id, 12u);
  EXPECT_EQ(keyframe.map_id, 5u);
  EXPECT_EQ(keyframe.session, 3u);  // Another odometry frame: the graph starts over.
  EXPECT_EQ(keyframe.stamp_ns, 1700000000000000001ull);
  EXPECT_EQ(keyframe.odometry_frame, "odom");
  EXPECT_DOUBLE_EQ(keyframe.odometry.position.x(), 2.0);
}

}  // namespace
