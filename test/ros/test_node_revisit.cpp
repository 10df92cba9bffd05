// The running node, fed two laps of the corridor, publishes loops whose keyframes are truly at
// the same place, with ids and stamps that agree with its keyframes topic, and relative poses
// that agree with the truth in the frame they name. Run by several launch files: odometry or tf
// poses; triangulated keypoint depths or a depth topic, with poses in the camera or base frame;
// a camera with a distorted lens.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <vector>

#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/sim/distorted_view.h"
#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

Eigen::Isometry3d bodyPose(const Pose2D& pose) {
  return planarPose(pose.x, pose.y, pose.yaw).toIsometry();
}

// The camera's optical frame in the world for a robot at `pose`, mounted as configured by default.
Eigen::Isometry3d cameraPose(const Pose2D& pose) {
  return bodyPose(pose) * CameraMount{}.toPose().toIsometry();
}

}  // namespace

TEST(LoopClosureNode, RevisitPublishesLoopsThatMatchTheTruth) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 2.0;
  options.start_stamp = 1700000000.123456789;  // Epoch-scale stamps, as on a real robot.
  SequenceGenerator sequence(world, CameraModel{}, options);
  // ~lens_k1 (and ~lens_k2): the camera has a plumb_bob lens, named in camera_info.
  std::optional<DistortedView> lens;
  double k1 = 0.0, k2 = 0.0;
  if (ros::param::get("~lens_k1", k1)) {
    ros::param::get("~lens_k2", k2);
    lens.emplace(world, CameraModel{}, options, std::vector<double>{k1, k2, 0.0, 0.0, 0.0});
    harness.setLens(lens->coefficients());
  }
  std::map<ros::Time, Pose2D> truth;
  ros::WallRate rate(test_support::kPublishRateHz);
  SequenceFrame frame;
  while (ros::ok() && sequence.next(&frame)) {
    truth[ros::Time(frame.stamp)] = frame.truth;
    harness.publish(frame.stamp, frame.odom, lens ? lens->render(frame) : frame.image);
    if (harness.depthWanted())
      harness.publishDepth(frame.stamp, world.renderDepth(frame.truth, {}));
    ros::spinOnce();
    rate.sleep();
  }
  harness.waitUntilQuiet();

  // A launch file may lower it (~min_keyframes).
  int min_keyframes = 400;
  ros::param::get("~min_keyframes", min_keyframes);
  // At 6x speed on a loaded machine the worker may fall behind: it then drops the oldest queued
  // keyframe and counts it (never stalling the camera callback). Every keyframe is published or
  // counted, and most are published.
  const std::string dropped_text = harness.diagnostic("keyframes dropped (worker busy)");
  ASSERT_FALSE(dropped_text.empty()) << "no diagnostics from the node";
  const size_t dropped = std::stoul(dropped_text);
  EXPECT_GT(harness.keyframes().size() + dropped, static_cast<size_t>(min_keyframes));
  EXPECT_LT(dropped, harness.keyframes().size() / 4);
  double min_score = 0.0;
  ASSERT_TRUE(ros::param::get("/loop_closure/advanced/acceptance/min_score", min_score));
  bool publish_scale_free_pose = false;
  ros::param::get("/loop_closure/advanced/verification/publish_scale_free_pose",
                  publish_scale_free_pose);
  bool use_depth = false;
  ros::param::get("/loop_closure/use_depth", use_depth);
  std::string relative_pose_frame = "camera";
  ros::param::get("/loop_closure/advanced/relative_pose_frame", relative_pose_frame);
  ASSERT_GE(harness.loops().size(), 5u);
  std::vector<std::pair<double, double>> metric_errors;  // Metres, degrees.
  std::vector<double> scale_free_turn_errors_deg;
  std::size_t orb_verified = 0;  // Loops the geometric check confirmed (others: appearance).
  for (const LoopClosure& loop : harness.loops()) {
    // What a failure needs to be told apart: a neighbour of the true match, or another place.
    SCOPED_TRACE("loop " + std::to_string(loop.query_id) + " -> " + std::to_string(loop.match_id) +
                 ": score " + std::to_string(loop.score) + ", " +
                 std::to_string(loop.consistent_frames) + " consistent keyframes, " +
                 (loop.verified
                      ? "verified, " + std::to_string(loop.inliers) + " inliers"
                      : "by appearance, " + std::to_string(loop.appearance_inliers) + " cells") +
                 (loop.relative_pose_metric ? ", metric pose" : ""));
    ASSERT_EQ(harness.keyframes().count(loop.query_id), 1u);
    ASSERT_EQ(harness.keyframes().count(loop.match_id), 1u);
    EXPECT_EQ(harness.keyframes().at(loop.query_id), loop.query_stamp);
    EXPECT_EQ(harness.keyframes().at(loop.match_id), loop.match_stamp);
    // Stamps are the images' own, to the nanosecond, so a backend can look them up exactly.
    ASSERT_EQ(truth.count(loop.query_stamp), 1u);
    ASSERT_EQ(truth.count(loop.match_stamp), 1u);
    const Pose2D& query = truth.at(loop.query_stamp);
    const Pose2D& match = truth.at(loop.match_stamp);
    EXPECT_TRUE(eval::TrueLoopRule{}.isTrueLoop({query.x, query.y, 0.0}, loop.query_stamp.toSec(),
                                                {match.x, match.y, 0.0}, loop.match_stamp.toSec()))
        << std::hypot(query.x - match.x, query.y - match.y) << " m apart";
    EXPECT_GT(loop.query_id, loop.match_id);
    EXPECT_GE(loop.score, min_score);
    // camera_info came with the images, so every loop passed the geometric check, or where ORB
    // could not confirm the place, the appearance check, without a pose.
    EXPECT_NE(loop.verified, loop.appearance_verified);
    if (loop.appearance_verified) {
      EXPECT_FALSE(loop.has_relative_pose);
      EXPECT_GE(loop.appearance_inliers, 28u);
      continue;
    }
    ++orb_verified;
    // Inliers of the published pose: PnP's (advanced/metric_pose/min_inliers) or the two views'.
    EXPECT_GE(loop.inliers, loop.relative_pose_metric ? 20u : 30u);
    // Metric poses (keypoint depths triangulated with the odometry, then PnP) are checked
    // against the truth; scale-free ones, published here on request, by their turn only.
    if (loop.has_relative_pose) {
      const auto& p = loop.relative_pose.pose;
      const Eigen::Quaterniond rotation(p.orientation.w, p.orientation.x, p.orientation.y,
                                        p.orientation.z);
      // Metric poses go out in the frame asked for; scale-free ones stay in the camera's.
      const bool in_base = loop.relative_pose_metric && relative_pose_frame == "base";
      EXPECT_EQ(loop.relative_pose_frame, in_base ? "base_link" : "camera");
      const Eigen::Isometry3d truth = in_base ? bodyPose(query).inverse() * bodyPose(match)
                                              : cameraPose(query).inverse() * cameraPose(match);
      const double rotation_error =
          rotation.angularDistance(Eigen::Quaterniond(truth.linear())) * 180.0 / M_PI;
      if (loop.relative_pose_metric) {
        const double translation_error =
            (Eigen::Vector3d(p.position.x, p.position.y, p.position.z) - truth.translation())
                .norm();
        metric_errors.emplace_back(translation_error, rotation_error);
      } else {
        EXPECT_TRUE(publish_scale_free_pose);
        scale_free_turn_errors_deg.push_back(rotation_error);
      }
    }
    EXPECT_EQ(loop.header.frame_id, "odom");
  }
  // Two views alone leave about one scale-free pose in four in a wrong minimum a few degrees away
  // (docs/how_it_works.md, "Geometric verification"), so these check that the message carries the
  // estimate (a wrong convention would miss every one), not that each pose is right; accuracy is
  // asserted on generated pairs in the core tests.
  std::size_t metric_within = 0;
  for (const auto& [translation, rotation] : metric_errors) {
    metric_within += translation < 0.25 && rotation < 2.0 ? 1 : 0;
  }
  std::size_t scale_free_within = 0;
  for (const double error : scale_free_turn_errors_deg) scale_free_within += error < 2.0 ? 1 : 0;
  std::vector<double> translations;
  std::vector<double> rotations;
  for (const auto& [translation, rotation] : metric_errors) {
    translations.push_back(translation);
    rotations.push_back(rotation);
  }
  std::printf(
      "%zu loops: %zu metric poses (median error %.3f m, %.2f deg), %zu within 0.25 m / 2 deg; "
      "%zu scale-free, %zu within 2 deg\n",
      harness.loops().size(), metric_errors.size(), median(translations), median(rotations),
      metric_within, scale_free_turn_errors_deg.size(), scale_free_within);
  EXPECT_GE(metric_errors.size(), 5u);
  EXPECT_GE(10 * metric_within, 8 * metric_errors.size());  // Measured: 54 of 55.
  // A lens the detector ignored doubles the median error (bench/history.md, "distorted lens").
  double max_median_m = 1.0, max_median_deg = 10.0;
  ros::param::get("~max_median_translation_m", max_median_m);
  ros::param::get("~max_median_rotation_deg", max_median_deg);
  EXPECT_LE(median(translations), max_median_m);
  EXPECT_LE(median(rotations), max_median_deg);
  // Depth images give every keypoint a depth: nearly every loop ORB confirmed gets a metric pose
  // (those the appearance check confirmed have no pose by design).
  if (use_depth) {
    EXPECT_GE(10 * metric_errors.size(), 9 * orb_verified);
    EXPECT_EQ(harness.diagnostic("keyframes without depth"), "0");
  }
  // A wrong convention would miss every one; the share is only asserted on enough of them.
  if (!scale_free_turn_errors_deg.empty()) {
    EXPECT_GT(scale_free_within, 0u);
  }
  if (scale_free_turn_errors_deg.size() >= 8) {
    EXPECT_GE(2 * scale_free_within, scale_free_turn_errors_deg.size());
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_revisit");
  return RUN_ALL_TESTS();
}
