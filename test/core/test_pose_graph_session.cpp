// The pose_graph node's bookkeeping (PoseGraphSession), without ROS: what enters the graph, what
// waits, what is left out and why, and a chain per map and session (its thread:
// test_pose_graph_runtime.cpp).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../fuzz/pose_graph_session_input.h"
#include "kept_fuzz_inputs.h"
#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "pose_graph_fixtures.h"

namespace landmark_loop_closure {
namespace {

using namespace pose_graph_fixtures;

TEST(PoseGraphSession, ALoopPublishedBeforeItsQueryKeyframeWaitsForIt) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 5));
  const GraphStep early = session.process({loopBetween(6, 1)});
  EXPECT_TRUE(early.verdicts.empty());
  EXPECT_FALSE(early.changed);
  EXPECT_EQ(session.graph().loops(), 0u);

  const GraphStep arrived = session.process(keyframes(5, 7));
  ASSERT_EQ(arrived.verdicts.size(), 1u);
  EXPECT_EQ(arrived.verdicts[0].decision, "accepted");
  EXPECT_EQ(arrived.verdicts[0].loop.query_stamp_ns, 7 * kSecond);
  EXPECT_TRUE(arrived.changed);
  EXPECT_TRUE(arrived.publish_paths);  // It was optimised.
  EXPECT_EQ(session.graph().activeLoops(), 1u);
  ASSERT_EQ(session.graphLoops().size(), 1u);
  EXPECT_EQ(session.graphLoops()[0].constraint.query_id, 6u);
}

TEST(PoseGraphSession, LoopsTheMetricGraphCannotTakeAreLeftOutWithTheirReason) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 20));
  GraphLoop appearance_only = loopBetween(15, 2);
  appearance_only.has_relative_pose = false;
  GraphLoop scale_free = loopBetween(16, 2);
  scale_free.relative_pose_metric = false;
  // Its match is a keyframe of a loaded map: published by the run that stored it, not to this
  // graph.
  GraphLoop earlier_run = loopBetween(17, 2);
  earlier_run.constraint.match_id = 500;
  earlier_run.match_session = 0;
  earlier_run.query_session = 1;
  GraphLoop unknown_frame = loopBetween(19, 2);
  unknown_frame.relative_pose_frame = "rear_camera";
  const GraphStep step = session.process({appearance_only, scale_free, earlier_run, unknown_frame});
  ASSERT_EQ(step.verdicts.size(), 4u);
  for (const GraphLoopVerdict& verdict : step.verdicts) {
    EXPECT_EQ(verdict.decision, "left_out") << verdict.loop.constraint.query_id;
    EXPECT_EQ(verdict.error_sd, 0.0);
  }
  EXPECT_NE(step.verdicts[0].detail.find("no relative pose"), std::string::npos);
  EXPECT_NE(step.verdicts[1].detail.find("scale-free"), std::string::npos);
  EXPECT_EQ(step.verdicts[2].detail,
            "its match is a keyframe of an earlier run this graph never received");
  EXPECT_EQ(step.verdicts[3].detail, "no tf base_link -> 'rear_camera'");  // The lookup's words.
  EXPECT_FALSE(step.changed);
  EXPECT_EQ(session.graph().loops(), 0u);
  const std::string summary = session.summary();
  EXPECT_NE(summary.find("left out 1: scale-free"), std::string::npos) << summary;
  EXPECT_NE(summary.find("left out 1: its frame is not on tf"), std::string::npos) << summary;
}

TEST(PoseGraphSession, ALoopInTheCameraFrameIsTurnedIntoTheBaseFrame) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 20));
  // Seen from a camera 0.2 m ahead of the base, the true loop has the same translation (the
  // camera is not turned): in the base frame it is the odometry's, so it fits.
  GraphLoop camera_loop = loopBetween(19, 3);
  camera_loop.relative_pose_frame = "camera";
  const GraphStep step = session.process({camera_loop});
  ASSERT_EQ(step.verdicts.size(), 1u);
  EXPECT_EQ(step.verdicts[0].decision, "accepted") << step.verdicts[0].detail;
}

// Issue 67 point 5: a detector on base_footprint publishing in its base frame, a graph on
// base_link: the loop's frame is not the graph's base, but it is not the camera's either, and the
// mount must not be applied to it (it was, silently, before the graph knew the detector's frame).
TEST(PoseGraphSession, ALoopInTheDetectorsOtherBaseFrameIsLeftOutNotTakenForTheCamera) {
  PoseGraphNodeOptions options = eachLoopOnItsOwn();
  options.detector_base_frame = "base_footprint";
  bool mount_asked = false;
  PoseGraphSession session(options, [&](const std::string& frame, std::string* problem) {
    mount_asked = true;
    return cameraOnly(frame, problem);
  });
  session.process(keyframes(0, 20));
  GraphLoop detector_base_loop = loopBetween(19, 3);
  detector_base_loop.relative_pose_frame = "base_footprint";
  GraphLoop camera_loop = loopBetween(18, 2);
  camera_loop.relative_pose_frame = "camera";
  const GraphStep step = session.process({detector_base_loop, camera_loop});
  ASSERT_EQ(step.verdicts.size(), 2u);
  EXPECT_EQ(step.verdicts[0].decision, "left_out");
  EXPECT_NE(step.verdicts[0].detail.find("detector's base_frame 'base_footprint'"),
            std::string::npos)
      << step.verdicts[0].detail;
  EXPECT_EQ(step.verdicts[1].decision, "accepted") << step.verdicts[1].detail;
  EXPECT_TRUE(mount_asked) << "the camera's frame still goes through the mount";
}

// As the detector (test_shipped_config): with no camera_mount value set, tf is asked first.
TEST(PoseGraphNodeOptions, WithNoMountValueSetTfIsAskedFirst) {
  PoseGraphNodeOptions options;
  EXPECT_TRUE(options.mountFromTfWhereKnown());
  PoseGraphNodeOptions set = options;
  set.camera_mount.x = 0.2;
  EXPECT_FALSE(set.mountFromTfWhereKnown());
  PoseGraphNodeOptions from_tf = options;
  from_tf.camera_mount_from_tf = true;
  EXPECT_FALSE(from_tf.mountFromTfWhereKnown());
}

TEST(PoseGraphSession, WithoutAMountLookupOnlyBaseFrameLoopsEnter) {
  PoseGraphSession session(eachLoopOnItsOwn(), MountLookup());
  session.process(keyframes(0, 20));
  GraphLoop camera_loop = loopBetween(19, 3);
  camera_loop.relative_pose_frame = "camera";
  const GraphStep step = session.process({camera_loop, loopBetween(18, 2)});
  ASSERT_EQ(step.verdicts.size(), 2u);
  EXPECT_EQ(step.verdicts[0].decision, "left_out");
  EXPECT_NE(step.verdicts[0].detail.find("no camera mount is known"), std::string::npos)
      << step.verdicts[0].detail;
  EXPECT_EQ(step.verdicts[1].decision, "accepted") << step.verdicts[1].detail;
}

TEST(PoseGraphSession, BadInputIsNamedAndTheGraphKeepsWhatItHas) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 5));
  GraphKeyframe broken = keyframeAt(5);
  broken.odometry.position.x() = std::nan("");
  const GraphStep dropped = session.process({broken});
  EXPECT_TRUE(hasNotice(dropped, GraphNotice::Kind::kKeyframeDropped, "keyframe dropped: "));
  EXPECT_FALSE(dropped.changed);
  EXPECT_EQ(session.graph().keyframes(), 5u);

  GraphLoop no_covariance = loopBetween(4, 1);
  no_covariance.constraint.covariance.setZero();
  const GraphStep refused = session.process({no_covariance});
  ASSERT_EQ(refused.verdicts.size(), 1u);
  EXPECT_EQ(refused.verdicts[0].decision, "bad_covariance");
  EXPECT_TRUE(
      hasNotice(refused, GraphNotice::Kind::kLoopBadInput, "loop 4 -> 1 dropped as bad input"));

  GraphLoop far_off = loopBetween(4, 1);
  far_off.constraint.query_T_match.translation().y() = 50.0;
  const GraphStep inconsistent = session.process({far_off});
  ASSERT_EQ(inconsistent.verdicts.size(), 1u);
  EXPECT_EQ(inconsistent.verdicts[0].decision, "inconsistent");
  EXPECT_TRUE(hasNotice(inconsistent, GraphNotice::Kind::kLoopRefused, "loop 4 -> 1 refused"));
  EXPECT_EQ(session.graph().activeLoops(), 0u);
  EXPECT_EQ(session.graph().keyframes(), 5u);
}

TEST(PoseGraphSession, LoopsForKeyframesThatNeverComeDoNotPileUp) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 5));
  std::vector<PoseGraphSession::Input> strays;
  for (uint64_t k = 0; k < 150; ++k) strays.emplace_back(loopBetween(1000 + k, 1));
  const GraphStep step = session.process(strays);
  // 100 wait for their keyframes; the oldest 50 go to the graph, which does not know them.
  ASSERT_EQ(step.verdicts.size(), 50u);
  for (const GraphLoopVerdict& verdict : step.verdicts) {
    EXPECT_EQ(verdict.decision, "unknown_keyframe");
  }
  EXPECT_EQ(step.verdicts.front().loop.constraint.query_id, 1000u);
  EXPECT_TRUE(hasNotice(step, GraphNotice::Kind::kLoopBadInput,
                        "keyframe 1000 of map 7 is not in the graph"));
}

// Issue 68: nothing is dropped at a new map. The detector was reset (a new map, its ids from 0
// again, time going on): a chain of its own, starting from the correction the robot had.
TEST(PoseGraphSession, AKeyframeOfAnotherMapStartsAChainOfItsOwn) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  ASSERT_TRUE(correctTwelveKeyframes(&session));
  const Eigen::Isometry3d correction = session.graph().mapFromOdometry();
  EXPECT_GT(correction.translation().norm(), 0.1);
  EXPECT_FALSE(session.pathsPublished());  // The first chain: nothing to clear.
  EXPECT_FALSE(session.pathsBehind());
  const Pose before = *session.optimisedPose(kMap, 11);

  GraphKeyframe other_map_first = keyframeAt(0, kMap + 1, 20 * kSecond);
  other_map_first.odometry.position.x() = 12.0;
  const GraphStep reset = session.process({other_map_first});
  EXPECT_FALSE(hasNotice(reset, GraphNotice::Kind::kNewGraph, ""));
  EXPECT_TRUE(hasNotice(reset, GraphNotice::Kind::kNewChain,
                        "keyframe 0 starts chain 1 (map 8, session 0: another odometry frame), "
                        "map -> odom where the graph left it"));
  EXPECT_TRUE(reset.publish_paths);
  EXPECT_EQ(session.graph().keyframes(), 13u);
  EXPECT_EQ(session.graph().chains(), 2u);
  EXPECT_TRUE(session.graph().mapFromOdometry().isApprox(correction));  // map -> odom holds.
  // Both maps' keyframe 0 are in the graph, each under its own map.
  ASSERT_TRUE(session.optimisedPose(kMap, 0));
  ASSERT_TRUE(session.optimisedPose(kMap + 1, 0));
  EXPECT_TRUE(session.optimisedPose(kMap, 11)->position.isApprox(before.position, 1e-9));
  EXPECT_EQ(session.keyOf(*session.graphId(kMap + 1, 0)), std::make_pair(kMap + 1, uint64_t{0}));
  EXPECT_EQ(*session.currentChain(), 1u);
  const std::string summary = session.summary();
  EXPECT_NE(summary.find("13 keyframes in 2 chain(s), 1 joined by loops to the first;"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("accepted 1"), std::string::npos) << summary;
}

TEST(PoseGraphSession, TimeGoingBackStartsANewGraph) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  ASSERT_TRUE(correctTwelveKeyframes(&session));
  // The bag played again: time went back, the odometry starts afresh.
  const GraphStep replay = session.process({keyframeAt(0, kMap, 1 * kSecond / 2)});
  EXPECT_TRUE(hasNotice(replay, GraphNotice::Kind::kNewGraph,
                        "time went back (a bag played again?), a new graph starts with it, "
                        "map -> odom from identity; the old graph's 12 keyframes, 1 chains and 1 "
                        "loops are dropped"));
  EXPECT_FALSE(replay.notices[0].throttle);
  EXPECT_TRUE(session.pathsPublished());  // The old graph's refusals are cleared, once.
  EXPECT_FALSE(session.pathsPublished());
  EXPECT_EQ(session.graph().keyframes(), 1u);
  EXPECT_TRUE(session.graph().mapFromOdometry().isApprox(Eigen::Isometry3d::Identity()));
  // Two detectors with their own clocks on one topic: throttled once the graph holds one.
  const GraphStep again = session.process({keyframeAt(0, kMap + 1, 1 * kSecond / 4)});
  EXPECT_TRUE(again.notices[0].throttle);
  const std::string summary = session.summary();
  EXPECT_NE(summary.find("1 keyframes in 1 chain(s), 1 joined by loops to the first (2 earlier "
                         "graph(s) dropped: time went back)"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("accepted 1"), std::string::npos) << summary;

  // A detector that loaded its map replays the bag on it: a new session of a map the graph holds
  // is a chain of it, whatever the stamps say.
  PoseGraphSession mapped(eachLoopOnItsOwn(), cameraOnly);
  mapped.process(keyframes(0, 12));
  GraphKeyframe second_run = keyframeAt(12, kMap, 1 * kSecond);
  second_run.session = 1;
  const GraphStep continued = mapped.process({second_run});
  EXPECT_FALSE(hasNotice(continued, GraphNotice::Kind::kNewGraph, ""));
  EXPECT_TRUE(hasNotice(continued, GraphNotice::Kind::kNewChain, "keyframe 12 starts chain 1"));
  EXPECT_EQ(mapped.graph().keyframes(), 13u);
}

// Issue 68: the odometry re-initialised (tracking lost): the new session floats where the robot
// was last seen until loops into the earlier session join it, then lies where they put it.
TEST(PoseGraphSession, ANewSessionFloatsWhereTheRobotWasLastSeenUntilLoopsJoinIt) {
  PoseGraphSession session(PoseGraphNodeOptions{}, cameraOnly);  // Loops confirmed in pairs.
  session.process(keyframes(0, 20));
  const Eigen::Vector3d last_seen = session.graph().optimisedPose(19)->position;
  // The odometry re-initialised at its origin while the robot drove back to x = 0: keyframe 20
  // is at (0, 0, 0) truly and in its new odometry frame, turned 90 degrees.
  const Eigen::Isometry3d new_frame(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  std::vector<PoseGraphSession::Input> second_run;
  for (uint64_t id = 20; id < 30; ++id) {
    GraphKeyframe keyframe = keyframeAt(id);
    keyframe.session = 1;
    keyframe.odometry = Pose::fromIsometry(
        new_frame * Eigen::Isometry3d(Eigen::Translation3d(static_cast<double>(id - 20), 0, 0)));
    second_run.emplace_back(keyframe);
  }
  const GraphStep started = session.process(second_run);
  EXPECT_TRUE(hasNotice(started, GraphNotice::Kind::kNewChain,
                        "keyframe 20 starts chain 1 (map 7, session 1: another odometry frame), "
                        "placed where the graph last saw the robot"));
  EXPECT_TRUE(session.optimisedPose(kMap, 20)->position.isApprox(last_seen, 1e-9));
  EXPECT_EQ(session.graph().chainsJoinedToFirst(), 1u);

  // Keyframe 20 + k is where keyframe k was: loops at the same place, pose identity.
  const auto samePlace = [](uint64_t query, uint64_t match) {
    GraphLoop loop = loopBetween(query, match);
    loop.query_session = 1;
    loop.constraint.query_T_match.setIdentity();
    return loop;
  };
  const GraphStep first = session.process({samePlace(24, 4)});
  ASSERT_EQ(first.verdicts.size(), 1u);
  EXPECT_EQ(first.verdicts[0].decision, "awaiting_confirmation");
  EXPECT_NE(first.verdicts[0].detail.find("joins chain 1 to chain 0"), std::string::npos)
      << first.verdicts[0].detail;
  const GraphStep second = session.process({samePlace(26, 6)});
  ASSERT_EQ(second.verdicts.size(), 2u);
  EXPECT_EQ(second.verdicts[0].decision, "accepted");
  EXPECT_EQ(second.verdicts[1].decision, "accepted");  // The first, confirmed.
  EXPECT_TRUE(second.publish_paths);
  EXPECT_EQ(session.graph().chainsJoinedToFirst(), 2u);
  for (uint64_t id = 20; id < 30; ++id) {
    EXPECT_LT((session.optimisedPose(kMap, id)->position -
               Eigen::Vector3d(static_cast<double>(id - 20), 0.0, 0.0))
                  .norm(),
              0.02)
        << id;
  }
  // The robot's map -> odom takes the new odometry frame onto the first.
  const Eigen::Isometry3d correction = session.graph().mapFromOdometry();
  EXPECT_TRUE((correction * new_frame).isApprox(Eigen::Isometry3d::Identity(), 1e-3));
  EXPECT_NE(session.summary().find("30 keyframes in 2 chain(s), 2 joined by loops to the first"),
            std::string::npos)
      << session.summary();
}

// Issue 68 point 3: two robots' keyframes, interleaved, each robot a map and a chain; a loop
// between their maps (LoopClosure.match_map_id) joins robot B's chain to robot A's, and B's
// path lies in A's frame.
TEST(PoseGraphSession, LoopsBetweenTwoRobotsMapsJoinTheirChains) {
  PoseGraphSession session(PoseGraphNodeOptions{}, cameraOnly);
  constexpr uint64_t kRobotA = kMap, kRobotB = kMap + 100;
  // Both drive x = 0..19; B's odometry frame is turned 90 degrees and 5 m off A's.
  const Eigen::Isometry3d b_frame =
      Eigen::Translation3d(0.0, 5.0, 0.0) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  for (uint64_t id = 0; id < 20; ++id) {
    GraphKeyframe a = keyframeAt(id, kRobotA, (2 * id + 1) * kSecond);
    GraphKeyframe b = keyframeAt(id, kRobotB, (2 * id + 2) * kSecond);
    a.odometry_frame = "a/odom";
    b.odometry_frame = "b/odom";
    b.odometry = Pose::fromIsometry(b_frame * a.odometry.toIsometry());
    std::vector<PoseGraphSession::Input> inputs{a, b};
    if (id == 8 || id == 10) {
      GraphLoop between = loopBetween(id, id);  // B's keyframe id at A's keyframe id.
      between.map_id = kRobotB;
      between.match_map_id = kRobotA;
      between.constraint.query_T_match.setIdentity();
      inputs.emplace_back(between);
    }
    session.process(inputs);
  }
  EXPECT_EQ(session.graph().chains(), 2u);
  EXPECT_EQ(session.graph().chainsJoinedToFirst(), 2u) << session.summary();
  for (uint64_t id = 0; id < 20; ++id) {
    EXPECT_LT((session.optimisedPose(kRobotB, id)->position -
               session.optimisedPose(kRobotA, id)->position)
                  .norm(),
              0.02)
        << id;
  }
  EXPECT_EQ(session.summary().find("left out"), std::string::npos) << session.summary();
  // map -> each robot's odometry frame: B's takes its frame onto A's (A's is about identity).
  const std::map<std::string, Eigen::Isometry3d> corrections = session.corrections();
  ASSERT_EQ(corrections.size(), 2u);
  EXPECT_TRUE((corrections.at("b/odom") * b_frame).isApprox(corrections.at("a/odom"), 1e-2))
      << corrections.at("b/odom").matrix();
}

// A camera-frame loop between two robots whose cameras sit differently: the query's end is turned
// by this graph's mount, the match's by the other robot's (LoopClosure.match_camera_mount); without
// the other robot's mount the loop is left out rather than biased by the difference.
TEST(PoseGraphSession, CameraFrameLoopsBetweenRobotsTakeEachRobotsMount) {
  constexpr uint64_t kRobotA = kMap, kRobotB = kMap + 100;
  const Eigen::Isometry3d b_frame =
      Eigen::Translation3d(0.0, 5.0, 0.0) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  std::string problem;
  const Eigen::Isometry3d b_mount = *cameraOnly("camera", &problem);  // This graph's robot.
  const Eigen::Isometry3d a_mount =  // Robot a's: 0.5 m ahead, 0.3 m up, pitched.
      Eigen::Translation3d(0.5, 0.0, 0.3) * Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitY());
  const auto drive = [&](bool with_mount, PoseGraphSession* session) {
    for (uint64_t id = 0; id < 20; ++id) {
      GraphKeyframe a = keyframeAt(id, kRobotA, (2 * id + 1) * kSecond);
      GraphKeyframe b = keyframeAt(id, kRobotB, (2 * id + 2) * kSecond);
      a.odometry_frame = "a/odom";
      b.odometry_frame = "b/odom";
      b.odometry = Pose::fromIsometry(b_frame * a.odometry.toIsometry());
      std::vector<PoseGraphSession::Input> inputs{a, b};
      if (id == 8 || id == 10) {
        GraphLoop between = loopBetween(id, id);  // The bases coincide: identity between them.
        between.map_id = kRobotB;
        between.match_map_id = kRobotA;
        between.relative_pose_frame = "camera";
        between.constraint.query_T_match = b_mount.inverse() * a_mount;
        if (with_mount) between.match_camera_mount = a_mount;
        inputs.emplace_back(between);
      }
      session->process(inputs);
    }
  };
  PoseGraphSession without(PoseGraphNodeOptions{}, cameraOnly);
  drive(false, &without);
  EXPECT_EQ(without.graph().chainsJoinedToFirst(), 1u) << without.summary();
  EXPECT_NE(without.summary().find("without the other robot's camera mount"), std::string::npos)
      << without.summary();
  PoseGraphSession with(PoseGraphNodeOptions{}, cameraOnly);
  drive(true, &with);
  EXPECT_EQ(with.graph().chainsJoinedToFirst(), 2u) << with.summary();
  for (uint64_t id = 0; id < 20; ++id) {
    EXPECT_LT(
        (with.optimisedPose(kRobotB, id)->position - with.optimisedPose(kRobotA, id)->position)
            .norm(),
        0.02)
        << id;
  }
}

// Two robots' keyframes reach the fleet's pose graph out of stamp order (each robot's own are in
// order): with `robots` set, only a map's own time going back starts a new graph.
TEST(PoseGraphSession, WithSeveralRobotsTimeGoesBackOnlyWithinAMap) {
  constexpr uint64_t kRobotA = kMap, kRobotB = kMap + 100;
  const auto interleaved = [&](PoseGraphSession* session) {
    size_t new_graphs = 0;
    for (uint64_t id = 0; id < 10; ++id) {
      // B's keyframe taken half a second before A's, received after it.
      GraphKeyframe a = keyframeAt(id, kRobotA, (id + 1) * kSecond);
      GraphKeyframe b = keyframeAt(id, kRobotB, (id + 1) * kSecond - kSecond / 2);
      a.odometry_frame = "a/odom";
      b.odometry_frame = "b/odom";
      const GraphStep step = session->process({a, b});
      new_graphs += hasNotice(step, GraphNotice::Kind::kNewGraph, "") ? 1 : 0;
    }
    return new_graphs;
  };
  PoseGraphSession one_robot(PoseGraphNodeOptions{}, cameraOnly);
  EXPECT_GT(interleaved(&one_robot), 0u);  // Taken for a bag played again, as before.

  PoseGraphNodeOptions fleet;
  fleet.robots = "/robot_a, /robot_b";
  PoseGraphSession robots(fleet, cameraOnly);
  EXPECT_EQ(interleaved(&robots), 0u);
  EXPECT_EQ(robots.graph().keyframes(), 20u);
  EXPECT_EQ(robots.graph().chains(), 2u);
  // A's own time going back (its bag played again) still starts a new graph.
  const GraphStep step = robots.process({keyframeAt(11, kRobotA, kSecond / 4)});
  EXPECT_TRUE(hasNotice(step, GraphNotice::Kind::kNewGraph, "")) << robots.summary();
  EXPECT_EQ(robots.graph().keyframes(), 1u);
}

TEST(PoseGraphSession, ABadKeyframeOfAnotherSessionOrMapDoesNotReplaceTheGraph) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  session.process(keyframes(0, 12));
  GraphKeyframe broken_session = keyframeAt(12);
  broken_session.session = 1;
  broken_session.odometry.position.x() = std::nan("");
  GraphKeyframe broken_map = keyframeAt(13, kMap + 1);
  broken_map.odometry.orientation.coeffs() << 0.0, 0.0, 0.0, 2.0;
  const GraphStep step = session.process({broken_session, broken_map});
  EXPECT_FALSE(hasNotice(step, GraphNotice::Kind::kNewGraph, ""));
  EXPECT_TRUE(hasNotice(step, GraphNotice::Kind::kKeyframeDropped, "keyframe 12: pose not finite"));
  EXPECT_TRUE(hasNotice(step, GraphNotice::Kind::kKeyframeDropped, "keyframe 13: pose not finite"));
  EXPECT_EQ(session.graph().keyframes(), 12u);
  EXPECT_TRUE(session.graph().mapFromOdometry().matrix().allFinite());
}

TEST(PoseGraphSession, PathsArePublishedEveryTenKeyframesAndAfterEachOptimisation) {
  PoseGraphSession session(eachLoopOnItsOwn(), cameraOnly);
  std::vector<bool> published;
  for (uint64_t id = 0; id < 20; ++id) {
    published.push_back(session.process({keyframeAt(id)}).publish_paths);
  }
  for (uint64_t id = 0; id < 20; ++id) EXPECT_EQ(published[id], (id + 1) % 10 == 0) << id;
  EXPECT_TRUE(session.process({loopBetween(19, 4)}).publish_paths);
  EXPECT_FALSE(session.process({}).publish_paths);
}

TEST(PoseGraphSession, EveryKeptFuzzInputKeepsItsInvariants) {
  // scripts/fuzz.sh starts from these inputs and keeps the ones that once failed here.
  const std::vector<KeptFuzzInput> inputs = keptFuzzInputs("fuzz_pose_graph_session");
  for (const KeptFuzzInput& input : inputs) {
    SCOPED_TRACE(input.path.string());
    EXPECT_TRUE(fuzz::replayPoseGraphSessionInput(input.bytes.data(), input.bytes.size()));
  }
  EXPECT_GE(inputs.size(), 2u);
}

}  // namespace
}  // namespace landmark_loop_closure
