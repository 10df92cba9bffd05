// LoopClosure.msg's contract for loops between robots: a backend that reads nothing but the
// message's documentation builds the right graph for two robots that are both in session 0 and
// both call their odometry frame "odom", with cameras mounted differently.
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "../../src/messages/ros_conversions.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/geometry/metric_pose.h"

using namespace landmark_loop_closure;

namespace {

Eigen::Isometry3d isometryOf(const geometry_msgs::Pose& pose) {
  return Eigen::Translation3d(pose.position.x, pose.position.y, pose.position.z) *
         Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y,
                            pose.orientation.z)
             .normalized();
}

RelativePose relativeOf(const Eigen::Isometry3d& transform) {
  RelativePose pose;
  pose.rotation = transform.rotation();
  pose.translation = transform.translation();
  pose.metric = true;
  pose.covariance = 1e-4 * Eigen::Matrix<double, 6, 6>::Identity();
  return pose;
}

/// The test backend: only what LoopClosure.msg says. Odometry frames are keyed by (map,
/// session); a camera-frame pose is put between the bases as M_query T M_match^-1, M_match the
/// message's match_camera_mount where it has one (a loop between robots), else the backend's
/// own robot's mount. Each loop then says how the match's odometry frame lies in the query's.
struct DocumentationBackend {
  using FrameKey = std::pair<uint64_t, uint32_t>;
  std::string base_frame;
  Eigen::Isometry3d own_mount;
  /// query frame <- match frame, every estimate of it.
  std::map<std::pair<FrameKey, FrameKey>, std::vector<Eigen::Isometry3d>> frame_offsets;
  std::set<FrameKey> frames;

  bool add(const LoopClosure& loop) {
    if (!loop.has_relative_pose || !loop.relative_pose_metric) return false;
    const FrameKey query{loop.map_id, loop.query_session};
    const FrameKey match{loop.match_map_id != 0 ? loop.match_map_id : loop.map_id,
                         loop.match_session};
    Eigen::Isometry3d bases = isometryOf(loop.relative_pose.pose);
    if (loop.relative_pose_frame != base_frame) {
      const bool between_maps = match.first != query.first;
      if (between_maps && !loop.has_match_camera_mount) return false;
      const Eigen::Isometry3d match_mount =
          loop.has_match_camera_mount ? isometryOf(loop.match_camera_mount) : own_mount;
      bases = own_mount * bases * match_mount.inverse();
    }
    frames.insert(query);
    frames.insert(match);
    frame_offsets[{query, match}].push_back(isometryOf(loop.query_pose) * bases *
                                            isometryOf(loop.match_pose).inverse());
    return true;
  }
};

}  // namespace

TEST(LoopContract, ABackendThatFollowsTheDocumentationJoinsTwoRobotsBothInSessionZero) {
  constexpr uint64_t kMapA = 11, kMapB = 22;
  // Robot a's odometry frame is the world's; robot b's started 4 m to the side, turned.
  const Eigen::Isometry3d world_T_b_odom =
      Eigen::Translation3d(3.0, -4.0, 0.0) * Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ());
  CameraMount mount_a;  // Robot a: the camera 1.2 m up, looking ahead.
  mount_a.z = 1.2;
  CameraMount mount_b;  // Robot b: 0.3 m ahead of its base, pitched 10 degrees down.
  mount_b.x = 0.3;
  mount_b.z = 0.9;
  mount_b.roll = -(90.0 + 10.0) * M_PI / 180.0;  // The optical axis 10 degrees down.
  const Eigen::Isometry3d ma = mount_a.toPose().toIsometry();
  const Eigen::Isometry3d mb = mount_b.toPose().toIsometry();
  const auto world_a = [](int i) { return planarPose(1.0 * i, 0.0, 0.0).toIsometry(); };
  const auto world_b = [](int i) { return planarPose(1.0 * i + 0.1, 0.3, 0.05).toIsometry(); };

  // Robot b's detector publishes: loops into robot a's map (the fleet), one with its pose in the
  // camera frames and one turned into the bases, and a loop within its own map.
  std::vector<LoopClosure> published;
  const auto between = [&](int i) {
    AcceptedLoop loop;
    loop.map_id = kMapB;
    loop.query_id = 100 + i;
    loop.query_session = 0;
    loop.query_pose = Pose::fromIsometry(world_T_b_odom.inverse() * world_b(i));
    loop.match_id = i;
    loop.match_session = 0;
    loop.match_pose = Pose::fromIsometry(world_a(i));  // In robot a's odometry frame.
    loop.match_map_id = kMapA;
    loop.match_odometry_frame = "odom";
    loop.match_camera_mount = mount_a.toPose();
    loop.relative_pose = relativeOf((world_b(i) * mb).inverse() * world_a(i) * ma);
    return loop;
  };
  for (int i = 0; i < 4; ++i) {
    published.push_back(
        toLoopMsg(between(i), ros::Time(100.0 + i), ros::Time(1.0 + i), "odom", "robot_b/camera"));
  }
  AcceptedLoop in_bases = between(5);
  in_bases.relative_pose =
      inBodyFrames(*in_bases.relative_pose, mount_b.toPose(), *in_bases.match_camera_mount);
  published.push_back(toLoopMsg(in_bases, ros::Time(105.0), ros::Time(6.0), "odom", "base_link"));
  AcceptedLoop within;
  within.map_id = kMapB;
  within.query_id = 120;
  within.query_session = 0;
  within.query_pose = Pose::fromIsometry(world_T_b_odom.inverse() * world_b(9));
  within.match_id = 101;
  within.match_session = 0;
  within.match_pose = Pose::fromIsometry(world_T_b_odom.inverse() * world_b(1));
  within.relative_pose = relativeOf((world_b(9) * mb).inverse() * world_b(1) * mb);
  published.push_back(
      toLoopMsg(within, ros::Time(120.0), ros::Time(101.0), "odom", "robot_b/camera"));

  // What the message says of its frames.
  for (size_t k = 0; k + 1 < published.size(); ++k) {
    EXPECT_EQ(published[k].match_map_id, kMapA);
    EXPECT_EQ(published[k].match_frame_id, "odom");  // Robot a's name for its frame.
    EXPECT_TRUE(published[k].has_match_camera_mount);
  }
  EXPECT_EQ(published.back().match_map_id, kMapB);
  EXPECT_EQ(published.back().match_frame_id, published.back().header.frame_id);
  EXPECT_FALSE(published.back().has_match_camera_mount);

  DocumentationBackend backend{"base_link", mb, {}, {}};
  for (const LoopClosure& loop : published) EXPECT_TRUE(backend.add(loop));
  // Two odometry frames, though both robots are in session 0 and call it "odom".
  ASSERT_EQ(backend.frames.size(), 2u);
  const DocumentationBackend::FrameKey a{kMapA, 0}, b{kMapB, 0};
  ASSERT_EQ(backend.frame_offsets.at({b, a}).size(), 5u);
  const Eigen::Isometry3d truth = world_T_b_odom.inverse();  // b's odom <- a's odom.
  for (const Eigen::Isometry3d& offset : backend.frame_offsets.at({b, a})) {
    EXPECT_LT((offset.translation() - truth.translation()).norm(), 1e-9);
    EXPECT_LT((offset.linear() - truth.linear()).norm(), 1e-9);
  }
  // Within robot b's map its session's frame is its own.
  for (const Eigen::Isometry3d& offset : backend.frame_offsets.at({b, b})) {
    EXPECT_LT(offset.translation().norm(), 1e-9);
    EXPECT_LT((offset.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-9);
  }
  // Keyed by session alone the two frames would be one, and 5 m apart from themselves.
  EXPECT_GT(truth.translation().norm(), 4.0);

  // The reference backend reads the same: the other robot's mount, and both mounts applied.
  const GraphLoop graph_loop = graphLoopFromMsg(published[0]);
  ASSERT_TRUE(graph_loop.match_camera_mount);
  EXPECT_TRUE(graph_loop.match_camera_mount->isApprox(ma, 1e-12));
  const LoopConstraint constraint =
      loopInBaseFrames(graph_loop.constraint, mb, *graph_loop.match_camera_mount);
  const Eigen::Isometry3d true_bases = world_b(0).inverse() * world_a(0);
  EXPECT_TRUE(constraint.query_T_match.isApprox(true_bases, 1e-9));
  // Robot b's own mount at both ends is off by the difference between the mounts.
  const LoopConstraint one_mount = loopInBaseFrame(graph_loop.constraint, mb);
  EXPECT_GT((one_mount.query_T_match.translation() - true_bases.translation()).norm(), 0.2);
}
