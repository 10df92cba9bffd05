// Two robots on the generated corridor (issue 68, Done-when line 3): robot A maps lap 1 (and
// closes it), robot B drives one lap from another start, each with a detector and a map of its
// own; B keeps A's shared rows, searches each of its keyframes in them, fetches A's evidence for
// a chained candidate and checks it. Every loop between them must be true, most of B's revisited
// keyframes must find one, and the pose graph fed both robots' keyframes and the loops puts B's
// path in A's frame.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace landmark_loop_closure {
namespace {

using sim::CameraModel;
using sim::CorridorWorld;
using sim::SequenceFrame;
using sim::SequenceGenerator;
using sim::SequenceOptions;

struct Robot {
  std::string name;
  std::unique_ptr<LoopDetector> detector;
  std::map<uint64_t, SequenceFrame> truth;  ///< By keyframe id.
  std::vector<uint64_t> announced;          ///< Keyframe ids, as they became safe to share.
  std::map<uint64_t, GraphLoop> own_loops;  ///< Its detector's metric loops, by query id.
};

/// A metric loop as the pose graph node receives it (relative pose in the base frames: each end
/// turned by its own robot's camera mount).
GraphLoop graphLoop(uint64_t map_id, uint64_t match_map_id, uint64_t query_id,
                    uint32_t query_session, uint64_t match_id, uint32_t match_session,
                    const RelativePose& relative, const Pose& query_mount,
                    const Pose& match_mount) {
  GraphLoop loop;
  loop.map_id = map_id;
  loop.match_map_id = match_map_id;
  loop.query_session = query_session;
  loop.match_session = match_session;
  loop.has_relative_pose = loop.relative_pose_metric = true;
  loop.relative_pose_frame = PoseGraphNodeOptions{}.base_frame;
  LoopConstraint camera;
  camera.query_id = query_id;
  camera.match_id = match_id;
  camera.query_T_match.linear() = relative.rotation;
  camera.query_T_match.translation() = relative.translation;
  camera.covariance = relative.covariance;
  loop.constraint =
      loopInBaseFrames(camera, query_mount.toIsometry(), match_mount.toIsometry());
  return loop;
}

/// Drives frames [first, last) of `sequence` through the robot's detector; its odometry starts
/// at the identity at `first` (an odometry frame of its own).
void drive(SequenceGenerator& sequence, size_t first, size_t last, Robot* robot) {
  const Pose mount = *robot->detector->cameraMount();
  std::optional<Eigen::Isometry3d> start;
  robot->detector->map().announceKeyframes(true);
  SequenceFrame frame;
  while (sequence.next(&frame)) {
    if (frame.index < first) continue;
    if (frame.index >= last) break;
    Eigen::Isometry3d odometry =
        planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw).toIsometry();
    if (!start) start = odometry;
    const Pose pose = Pose::fromIsometry(start->inverse() * odometry);
    const FrameResult result =
        robot->detector->process(frame.stamp, pose, frame.image, CameraModel{}.intrinsics());
    if (result.admission.isKeyframe()) robot->truth[result.admission.keyframe_id] = frame;
    if (result.keyframe && result.keyframe->loop && result.keyframe->loop->relative_pose &&
        result.keyframe->loop->relative_pose->metric) {
      const AcceptedLoop& loop = *result.keyframe->loop;
      robot->own_loops[loop.query_id] =
          graphLoop(loop.map_id, loop.map_id, loop.query_id, loop.query_session, loop.match_id,
                    loop.match_session, *loop.relative_pose, mount, mount);
    }
    for (const AnnouncedKeyframe& announced : robot->detector->map().takeAnnounced()) {
      robot->announced.push_back(announced.summary.id);
    }
  }
}

Pose truthPose(const SequenceFrame& frame) {
  return planarPose(frame.truth.x, frame.truth.y, frame.truth.yaw);
}

GraphKeyframe graphKeyframe(const Robot& robot, uint64_t id) {
  const KeyframeSummary& summary =
      robot.detector->database().summary(*robot.detector->database().indexOf(id));
  GraphKeyframe keyframe;
  keyframe.id = id;
  keyframe.map_id = robot.detector->map().mapId();
  keyframe.session = summary.session;
  keyframe.odometry = summary.pose;
  keyframe.stamp_ns = static_cast<uint64_t>(summary.stamp * 1e9);
  keyframe.odometry_frame = robot.name + "/odom";
  return keyframe;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

/// What one run of the two robots measured.
struct FleetFigures {
  int loops = 0, false_loops = 0, with_pose = 0;
  double recall = 0.0;
  double b_rmse = 0.0;      ///< B's corrected keyframes in A's frame (m).
  double row_bytes = 0.0;   ///< A shared row.
  /// Metric loops between the robots against the truth, between the bases: each end turned by
  /// its own robot's mount, and (what a single mount gives) robot B's at both ends.
  double translation_error_m = 0.0, rotation_error_deg = 0.0;
  double one_mount_translation_error_m = 0.0, one_mount_rotation_error_deg = 0.0;
};

/// Robot A (the default camera) maps lap 1; robot B, its camera `b_camera` as its mount
/// `b_mount` says, drives one lap from 0.3 laps on and searches A's shared rows.
void runTwoRobots(const CameraModel& b_camera, const CameraMount& b_mount,
                  FleetFigures* figures) {
  const CorridorWorld world;
  SequenceOptions sequence_options;
  sequence_options.laps = 2.3;
  SequenceGenerator sequence(world, CameraModel{}, sequence_options);
  const size_t lap = static_cast<size_t>(sequence.size() / 2.3);

  const LoopDetectorOptions detector_options;
  LoopDetectorOptions b_options = detector_options;
  b_options.camera_mount = b_mount;
  Robot a, b;
  a.name = "robot_a";
  b.name = "robot_b";
  a.detector = std::make_unique<LoopDetector>(
      detector_options, makeDescriptorExtractor(detector_options.descriptor));
  b.detector =
      std::make_unique<LoopDetector>(b_options, makeDescriptorExtractor(b_options.descriptor));
  // A maps lap 1 and drives on to where it started, its own loops closing its lap; B drives
  // one lap from 0.3 laps on, after A.
  drive(sequence, 0, lap * 12 / 10, &a);
  SequenceGenerator second(world, b_camera, sequence_options);
  drive(second, lap * 13 / 10, lap * 23 / 10, &b);
  ASSERT_GT(a.announced.size(), 100u);
  ASSERT_GT(b.announced.size(), 100u);

  // B keeps every row A shared.
  FleetMatcher matcher(FleetOptions{}, b.detector->descriptorIdentity(),
                       b.detector->database().globalDimension());
  size_t row_bytes = 0;
  for (const uint64_t id : a.announced) {
    const std::optional<SharedKeyframe> row =
        sharedKeyframeOf(*a.detector, id, a.name, a.name + "/odom");
    ASSERT_TRUE(row);
    row_bytes += row->wireBytes();
    ASSERT_EQ(matcher.addRow(*row, 0.0, b.detector->map().mapId()), "");
  }

  // B searches each of its keyframes in them, in the order it shares them.
  const GeometricVerifier verifier(detector_options.verification);
  const PlaceCheckSettings settings{detector_options.verification, detector_options.appearance,
                                    detector_options.metric_pose};
  const eval::TrueLoopRule rule;
  const auto true_loop = [&](const SequenceFrame& query, const SequenceFrame& match) {
    return rule.isTrueLoop({query.truth.x, query.truth.y, 0.0}, query.stamp,
                           {match.truth.x, match.truth.y, 0.0}, match.stamp);
  };
  int revisited = 0, found = 0, loops = 0, false_loops = 0, fetched = 0, with_pose = 0;
  std::vector<double> translation_errors, rotation_errors, one_mount_translation_errors,
      one_mount_rotation_errors;
  const Pose b_mount_pose = *b.detector->cameraMount();
  size_t evidence_bytes = 0;
  std::vector<PoseGraphSession::Input> inputs;
  for (const uint64_t id : a.announced) {
    inputs.emplace_back(graphKeyframe(a, id));
    if (a.own_loops.count(id) > 0) inputs.emplace_back(a.own_loops.at(id));
  }
  for (const uint64_t id : b.announced) {
    const SequenceFrame& frame = b.truth.at(id);
    bool revisit = false;
    for (const auto& [a_id, a_frame] : a.truth) revisit = revisit || true_loop(frame, a_frame);
    revisited += revisit ? 1 : 0;
    inputs.emplace_back(graphKeyframe(b, id));
    if (b.own_loops.count(id) > 0) inputs.emplace_back(b.own_loops.at(id));
    const std::optional<SharedKeyframe> own =
        sharedKeyframeOf(*b.detector, id, b.name, b.name + "/odom");
    ASSERT_TRUE(own);
    const std::optional<FleetCandidate> candidate = matcher.query(*own);
    if (!candidate) continue;
    const std::optional<KeyframeEvidence> evidence =
        evidenceOf(*a.detector, candidate->match.id, CameraModel{}.intrinsics());
    ASSERT_TRUE(evidence);
    ++fetched;
    evidence_bytes += evidence->wireBytes();
    const std::shared_ptr<const KeyframeRecord> query = b.detector->database().findRecord(id);
    ASSERT_TRUE(query);
    const PlaceCheck check = checkFleetCandidate(
        verifier, settings, query->local_features, CameraModel{}.intrinsics(), *evidence,
        thumbnailCellsOf(*b.detector, query->thumbnail),
        thumbnailCellsOf(*a.detector, evidence->thumbnail), FleetOptions{}.appearance_confirms);
    if (!check.accepted) continue;
    ++loops;
    const bool is_true = true_loop(frame, a.truth.at(candidate->match.id));
    false_loops += is_true ? 0 : 1;
    found += (is_true && revisit) ? 1 : 0;
    if (!check.relative_pose || !check.relative_pose->metric) continue;
    ++with_pose;
    ASSERT_TRUE(evidence->camera_mount);  // A's mount comes with its evidence.
    const GraphLoop between = graphLoop(b.detector->map().mapId(), a.detector->map().mapId(), id,
                                        candidate->query_session, candidate->match.id,
                                        candidate->match.session, *check.relative_pose,
                                        b_mount_pose, *evidence->camera_mount);
    inputs.emplace_back(between);
    const Eigen::Isometry3d truth = truthPose(frame).toIsometry().inverse() *
                                    truthPose(a.truth.at(candidate->match.id)).toIsometry();
    const auto note_error = [&truth](const Eigen::Isometry3d& estimate,
                                     std::vector<double>* metres, std::vector<double>* degrees) {
      const Eigen::Isometry3d error = truth.inverse() * estimate;
      metres->push_back(error.translation().norm());
      degrees->push_back(Eigen::AngleAxisd(error.rotation()).angle() * 180.0 / M_PI);
    };
    note_error(between.constraint.query_T_match, &translation_errors, &rotation_errors);
    note_error(graphLoop(0, 0, 0, 0, 0, 0, *check.relative_pose, b_mount_pose, b_mount_pose)
                   .constraint.query_T_match,
               &one_mount_translation_errors, &one_mount_rotation_errors);
  }

  PoseGraphSession graph(PoseGraphNodeOptions{}, MountLookup());
  for (const PoseGraphSession::Input& input : inputs) graph.process({input});
  EXPECT_EQ(graph.graph().chains(), 2u);
  EXPECT_EQ(graph.graph().chainsJoinedToFirst(), 2u) << graph.summary();

  // B's path in A's frame: each B keyframe where the truth puts it relative to A's nearest
  // keyframe, as A's graph placed that one (A's own drift over its lap is A's map, not B's error).
  std::map<uint64_t, Pose> corrected_a;
  for (const uint64_t id : a.announced) {
    const std::optional<Pose> pose = graph.optimisedPose(a.detector->map().mapId(), id);
    ASSERT_TRUE(pose);
    corrected_a[id] = *pose;
  }
  double squares_in_a = 0.0;
  size_t placed = 0;
  std::vector<Pose> corrected, truth;
  for (const auto& [robot, ids] : {std::pair{&a, &a.announced}, std::pair{&b, &b.announced}}) {
    for (const uint64_t id : *ids) {
      const std::optional<Pose> pose = graph.optimisedPose(robot->detector->map().mapId(), id);
      ASSERT_TRUE(pose);
      corrected.push_back(*pose);
      truth.push_back(truthPose(robot->truth.at(id)));
    }
  }
  for (const uint64_t id : b.announced) {
    const SequenceFrame& frame = b.truth.at(id);
    std::optional<uint64_t> nearest;
    double nearest_m = 2.5;
    for (const auto& [a_id, a_pose] : corrected_a) {
      const SequenceFrame& a_frame = a.truth.at(a_id);
      const double metres =
          std::hypot(a_frame.truth.x - frame.truth.x, a_frame.truth.y - frame.truth.y);
      if (metres <= nearest_m) {
        nearest_m = metres;
        nearest = a_id;
      }
    }
    if (!nearest) continue;
    const Eigen::Isometry3d expected = corrected_a.at(*nearest).toIsometry() *
                                       truthPose(a.truth.at(*nearest)).toIsometry().inverse() *
                                       truthPose(frame).toIsometry();
    const Eigen::Vector3d error =
        graph.optimisedPose(b.detector->map().mapId(), id)->position - expected.translation();
    squares_in_a += error.head<2>().squaredNorm();
    ++placed;
  }
  ASSERT_GT(placed, b.announced.size() / 2);
  const double b_rmse = std::sqrt(squares_in_a / placed);
  const std::vector<double> errors = eval::similarityAlignedErrors(corrected, truth);
  double all_squares = 0.0;
  for (const double error : errors) all_squares += error * error;
  const double recall = revisited > 0 ? double(found) / revisited : 0.0;
  figures->loops = loops;
  figures->false_loops = false_loops;
  figures->with_pose = with_pose;
  figures->recall = recall;
  figures->b_rmse = b_rmse;
  figures->row_bytes = double(row_bytes) / a.announced.size();
  figures->translation_error_m = median(translation_errors);
  figures->rotation_error_deg = median(rotation_errors);
  figures->one_mount_translation_error_m = median(one_mount_translation_errors);
  figures->one_mount_rotation_error_deg = median(one_mount_rotation_errors);
  std::printf(
      "robot A %zu keyframes, robot B %zu (%d revisit A's places); %d candidates fetched, %d "
      "loops between them (%d false, %d with a metric pose), %d of the revisited keyframes found "
      "(%.0f %%); a shared row %.0f bytes, a fetched candidate's evidence %.0f bytes; B's RMSE "
      "in A's frame %.3f m (%zu keyframes; both robots against the truth, similarity-aligned, "
      "%.3f m); metric loops between them against the truth, median: %.3f m, %.2f deg with each "
      "robot's mount, %.3f m, %.2f deg with B's at both ends; %s\n",
      a.announced.size(), b.announced.size(), revisited, fetched, loops, false_loops, with_pose,
      found, 100.0 * recall, figures->row_bytes,
      fetched > 0 ? double(evidence_bytes) / fetched : 0.0, b_rmse, placed,
      std::sqrt(all_squares / errors.size()), figures->translation_error_m,
      figures->rotation_error_deg, figures->one_mount_translation_error_m,
      figures->one_mount_rotation_error_deg, graph.summary().c_str());
}

TEST(FleetOnCorridor, RobotBFindsRobotAsPlacesAndItsPathLiesInAsFrame) {
  FleetFigures figures;
  runTwoRobots(CameraModel{}, LoopDetectorOptions{}.camera_mount, &figures);
  EXPECT_EQ(figures.false_loops, 0);
  EXPECT_GE(figures.recall, 0.8);
  EXPECT_LE(figures.b_rmse, 0.05);
  EXPECT_LE(figures.row_bytes, 5000.0);
}

// Issue 81: robot B's camera sits 0.3 m ahead of its base and looks 10 degrees down; robot A's
// as before. The metric loops between them, each end turned by its own robot's mount, land on
// the truth between the bases, and B's corrected path lies in A's frame.
TEST(FleetOnCorridor, TwoDifferentlyMountedRobotsGetLoopsRightBetweenTheirBases) {
  CameraModel b_camera;
  b_camera.forward_m = 0.3;
  b_camera.pitch_rad = 10.0 * M_PI / 180.0;
  CameraMount b_mount = LoopDetectorOptions{}.camera_mount;
  b_mount.x = 0.3;
  b_mount.roll = -(90.0 + 10.0) * M_PI / 180.0;  // The optical axis 10 degrees down.
  FleetFigures figures;
  runTwoRobots(b_camera, b_mount, &figures);
  EXPECT_EQ(figures.false_loops, 0);
  EXPECT_GT(figures.with_pose, 20);
  EXPECT_LE(figures.translation_error_m, 0.05);
  EXPECT_LE(figures.rotation_error_deg, 0.5);
  EXPECT_LE(figures.b_rmse, 0.05);
  // B's mount at both ends is off by the difference between the two mounts.
  EXPECT_GT(figures.one_mount_translation_error_m, 0.1);
}

}  // namespace
}  // namespace landmark_loop_closure
