// An image's pose is the odometry interpolated to the image's stamp: between the two messages
// around it, the orientation by slerp; images the odometry cannot place say why.
#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "landmark_loop_closure/runtime/odometry_history.h"

using namespace landmark_loop_closure;

namespace {

Pose poseAt(double x, double yaw) {
  Pose pose;
  pose.position = Eigen::Vector3d(x, 2.0 * x, 0.5);
  pose.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

double yawOf(const Pose& pose) {
  const Eigen::Vector3d forward = pose.orientation * Eigen::Vector3d::UnitX();
  return std::atan2(forward.y(), forward.x());
}

}  // namespace

TEST(OdometryHistory, AnImageBetweenTwoMessagesGetsThePoseAtItsOwnStamp) {
  OdometryHistory history;
  history.add(10.0, poseAt(1.0, 0.0));
  history.add(10.1, poseAt(2.0, 0.4));
  const OdometryLookup lookup = history.at(10.025, 0.2);
  ASSERT_EQ(lookup.status, OdometryAt::kFound);
  EXPECT_NEAR(lookup.pose.position.x(), 1.25, 1e-9);
  EXPECT_NEAR(lookup.pose.position.y(), 2.5, 1e-9);
  EXPECT_NEAR(yawOf(lookup.pose), 0.1, 1e-9);
  EXPECT_NEAR(lookup.pose.orientation.norm(), 1.0, 1e-12);
  EXPECT_NEAR(lookup.interval, 0.1, 1e-12);
  // The nearest message (10.0) would be 0.25 m and 0.1 rad off.
}

TEST(OdometryHistory, AnImageAtAMessagesStampTakesIt) {
  OdometryHistory history;
  history.add(5.0, poseAt(1.0, 0.2));
  history.add(6.0, poseAt(9.0, 0.0));
  const OdometryLookup lookup = history.at(5.0, 0.1);  // The interval limit does not apply.
  ASSERT_EQ(lookup.status, OdometryAt::kFound);
  EXPECT_DOUBLE_EQ(lookup.pose.position.x(), 1.0);
  EXPECT_EQ(history.at(6.0, 0.1).status, OdometryAt::kFound);
}

TEST(OdometryHistory, ImagesItCannotPlaceSayWhy) {
  OdometryHistory history;
  EXPECT_EQ(history.at(1.0, 0.2).status, OdometryAt::kNoOdometry);
  history.add(10.0, poseAt(0.0, 0.0));
  history.add(10.1, poseAt(1.0, 0.0));
  history.add(11.0, poseAt(2.0, 0.0));
  EXPECT_EQ(history.at(11.05, 0.2).status, OdometryAt::kNotYet);
  EXPECT_EQ(history.at(9.9, 0.2).status, OdometryAt::kBeforeHistory);
  const OdometryLookup gap = history.at(10.5, 0.2);
  EXPECT_EQ(gap.status, OdometryAt::kGapTooLong);
  EXPECT_NEAR(gap.interval, 0.9, 1e-12);
  EXPECT_EQ(history.at(10.5, 1.0).status, OdometryAt::kFound);
}

TEST(OdometryHistory, OutOfOrderMessagesAreInsertedInPlaceAndTheOldestForgotten) {
  OdometryHistory history(3);
  history.add(2.0, poseAt(2.0, 0.0));
  history.add(1.0, poseAt(1.0, 0.0));  // Late.
  history.add(3.0, poseAt(3.0, 0.0));
  EXPECT_NEAR(history.at(1.5, 1.0).pose.position.x(), 1.5, 1e-12);
  history.add(3.0, poseAt(30.0, 0.0));  // Same stamp: replaces.
  EXPECT_EQ(history.size(), 3u);
  EXPECT_DOUBLE_EQ(history.at(3.0, 1.0).pose.position.x(), 30.0);
  history.add(4.0, poseAt(4.0, 0.0));
  EXPECT_EQ(history.size(), 3u);
  EXPECT_EQ(history.at(1.5, 1.0).status, OdometryAt::kBeforeHistory);
  EXPECT_DOUBLE_EQ(history.newest(), 4.0);
}

TEST(OdometryHistory, SlerpTakesTheShorterWayRound) {
  Pose a = poseAt(0.0, 3.0);
  Pose b = poseAt(0.0, -3.0);                        // 0.28 rad apart across +-pi, not 6 rad.
  b.orientation.coeffs() = -b.orientation.coeffs();  // The same rotation, other sign.
  const Pose middle = interpolatePose(a, b, 0.5);
  EXPECT_NEAR(std::abs(yawOf(middle)), M_PI, 1e-9);
}

// A bag played again: with a full history, every message of the new timeline would be older than
// all it holds and dropped, and so would every image.
TEST(OdometryHistory, AJumpBackStartsANewTimeline) {
  OdometryHistory history(5, 1.0);
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(history.add(100.0 + 0.1 * i, poseAt(i, 0.0)));
  EXPECT_FALSE(history.add(100.05, poseAt(0.5, 0.0))) << "a late message is no jump";
  EXPECT_TRUE(history.add(10.0, poseAt(7.0, 0.0)));
  EXPECT_EQ(history.size(), 1u);
  EXPECT_FALSE(history.add(10.1, poseAt(8.0, 0.0)));
  const OdometryLookup lookup = history.at(10.05, 0.2);
  ASSERT_EQ(lookup.status, OdometryAt::kFound);
  EXPECT_NEAR(lookup.pose.position.x(), 7.5, 1e-9);

  OdometryHistory whole_bag(5);  // jump_back_s 0: never.
  for (int i = 0; i < 5; ++i) whole_bag.add(100.0 + 0.1 * i, poseAt(i, 0.0));
  EXPECT_FALSE(whole_bag.add(10.0, poseAt(7.0, 0.0)));
  EXPECT_EQ(whole_bag.at(10.0, 0.2).status, OdometryAt::kBeforeHistory);
}
