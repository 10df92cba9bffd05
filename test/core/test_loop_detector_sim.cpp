// The whole core pipeline on the generated corridor with drifting odometry: the default options
// (landmark descriptors) and HOG with its own threshold.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/training.h"
#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/sim/sequence.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

struct RunSummary {
  int keyframes = 0;
  int loops = 0;
  int true_loops = 0;
  double worst_loop_distance = 0.0;
  int verified_loops = 0;
  int appearance_loops = 0;  ///< Confirmed by the appearance check where ORB could not.
  int appearance_loops_with_pose = 0;
  /// Rotation of the published relative poses (metric by default) against the truth.
  double worst_published_turn_error_deg = 0.0;
  int published_poses = 0;
  /// Scale-free poses the geometric check called well determined, and those within 2 deg.
  int scale_free_poses = 0;
  int scale_free_poses_within_2_deg = 0;
};

// Drives `laps` of the corridor with drifting odometry through `detector`; `on_keyframe` sees
// each keyframe's frame (with its true pose), id and result.
void driveCorridor(
    LoopDetector* detector, double laps,
    const std::function<void(const SequenceFrame&, uint64_t, const KeyframeResult&)>& on_keyframe) {
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = laps;
  SequenceGenerator sequence(world, CameraModel{}, options);
  SequenceFrame frame;
  while (sequence.next(&frame, false)) {
    const Pose odom = planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw);
    const FrameAdmission admission =
        detector->admit(frame.stamp, odom, CameraModel{}.width, CameraModel{}.height, CV_8UC1);
    if (!admission.isKeyframe()) continue;
    on_keyframe(frame, admission.keyframe_id,
                detector->addKeyframe(admission.keyframe_id, frame.stamp, odom,
                                      sequence.render(frame), CameraModel{}.intrinsics()));
  }
}

// The one rule every evaluation judges loops by (eval::TrueLoopRule), on the generated truth.
bool isTrueLoop(const SequenceFrame& query, const SequenceFrame& match) {
  return eval::TrueLoopRule{}.isTrueLoop({query.truth.x, query.truth.y, 0.0}, query.stamp,
                                         {match.truth.x, match.truth.y, 0.0}, match.stamp);
}

// Runs a route through the detector; a loop is true by eval::TrueLoopRule.
RunSummary run(double laps, const DescriptorOptions& descriptor, double min_score,
               const SequenceMatchingOptions& sequence = {}, int consistent_keyframes = 3) {
  LoopDetectorOptions detector_options;
  detector_options.acceptance.min_score = min_score;
  detector_options.acceptance.sequence = sequence;
  detector_options.acceptance.consistent_keyframes = consistent_keyframes;
  detector_options.descriptor.condition_window = descriptor.condition_window;
  LoopDetector detector(detector_options, makeDescriptorExtractor(descriptor));
  std::map<uint64_t, SequenceFrame> truth_by_keyframe;
  RunSummary summary;
  driveCorridor(
      &detector, laps, [&](const SequenceFrame& frame, uint64_t id, const KeyframeResult& result) {
        EXPECT_FALSE(result.error);
        truth_by_keyframe[id] = frame;
        ++summary.keyframes;
        if (!result.loop) return;
        const SequenceFrame& match_frame = truth_by_keyframe.at(result.loop->match_id);
        const Pose2D& match = match_frame.truth;
        const double distance = std::hypot(match.x - frame.truth.x, match.y - frame.truth.y);
        ++summary.loops;
        summary.true_loops += isTrueLoop(frame, match_frame) ? 1 : 0;
        summary.worst_loop_distance = std::max(summary.worst_loop_distance, distance);
        if (result.loop->verification) ++summary.verified_loops;
        if (result.loop->appearance) {
          ++summary.appearance_loops;
          if (result.loop->relative_pose) ++summary.appearance_loops_with_pose;
        }
        const double true_turn = std::abs(std::remainder(match.yaw - frame.truth.yaw, 2 * M_PI));
        const auto turn_error_deg = [&](const RelativePose& pose) {
          return std::abs(Eigen::AngleAxisd(pose.rotation).angle() - true_turn) * 180.0 / M_PI;
        };
        if (result.loop->relative_pose) {
          ++summary.published_poses;
          summary.worst_published_turn_error_deg = std::max(
              summary.worst_published_turn_error_deg, turn_error_deg(*result.loop->relative_pose));
        }
        if (result.loop->verification && result.loop->verification->accepted()) {
          ++summary.scale_free_poses;
          if (turn_error_deg(result.loop->verification->pose) < 2.0) {
            ++summary.scale_free_poses_within_2_deg;
          }
        }
      });
  return summary;
}

}  // namespace

DescriptorOptions hog() {
  DescriptorOptions options;
  options.type = "hog";
  options.condition_window = 0;  // hog's threshold 0.7 is on the raw cosine.
  return options;
}

const double kDefaultMinScore = LoopDetectorOptions{}.acceptance.min_score;

TEST(LoopDetectorOnCorridor, RevisitGivesOnlyTrueLoops) {
  const RunSummary summary = run(2.0, DescriptorOptions{}, kDefaultMinScore);
  EXPECT_GT(summary.keyframes, 300);
  EXPECT_GE(summary.loops, 5);
  EXPECT_EQ(summary.true_loops, summary.loops)
      << "worst loop " << summary.worst_loop_distance << " m";
  // Intrinsics were given: every accepted loop passed the geometric check, or where ORB could not
  // confirm the place (the second lap's other light), the appearance check, which gives no pose.
  // Every published relative pose (metric: depths triangulated from the odometry) has the true
  // change of heading; the two-view scale-free poses, not published by default, mostly do
  // (README: about one in four is further off than its covariance says).
  EXPECT_EQ(summary.verified_loops + summary.appearance_loops, summary.loops);
  EXPECT_GT(summary.verified_loops, summary.appearance_loops);
  EXPECT_EQ(summary.appearance_loops_with_pose, 0);
  EXPECT_GE(summary.published_poses, 5);
  EXPECT_LT(summary.worst_published_turn_error_deg, 2.0);
  EXPECT_GE(summary.scale_free_poses_within_2_deg, 0.7 * summary.scale_free_poses)
      << summary.scale_free_poses_within_2_deg << " of " << summary.scale_free_poses;
}

TEST(LoopDetectorOnCorridor, OneWayRouteGivesNoLoop) {
  const RunSummary summary = run(0.9, DescriptorOptions{}, kDefaultMinScore);
  EXPECT_GT(summary.keyframes, 150);
  EXPECT_EQ(summary.loops, 0);
}

TEST(LoopDetectorOnCorridor, SequenceMatchingGivesOnlyTrueLoopsAndNoneOnAOneWayRoute) {
  SequenceMatchingOptions sequence;
  sequence.length = 8;
  const RunSummary revisit = run(2.0, DescriptorOptions{}, kDefaultMinScore, sequence, 1);
  EXPECT_GE(revisit.loops, 5);
  EXPECT_EQ(revisit.true_loops, revisit.loops) << "worst loop " << revisit.worst_loop_distance;
  EXPECT_EQ(revisit.verified_loops + revisit.appearance_loops, revisit.loops);
  const RunSummary one_way = run(0.9, DescriptorOptions{}, kDefaultMinScore, sequence, 1);
  EXPECT_GT(one_way.keyframes, 150);
  EXPECT_EQ(one_way.loops, 0);
}

TEST(LoopDetectorOnCorridor, HogAtItsThresholdGivesOnlyTrueLoops) {
  const RunSummary revisit = run(2.0, hog(), 0.7);
  EXPECT_GE(revisit.loops, 5);
  EXPECT_EQ(revisit.true_loops, revisit.loops) << "worst loop " << revisit.worst_loop_distance;
  EXPECT_EQ(run(0.9, hog(), 0.7).loops, 0);
}

namespace {

// Keypoints of the stored keyframes that got a triangulated depth, over the first metres.
int triangulatedKeypoints(LoopDetector* detector) {
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 0.1;
  SequenceGenerator sequence(world, CameraModel{}, options);
  SequenceFrame frame;
  while (sequence.next(&frame)) {
    detector->process(frame.stamp, planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw),
                      frame.image, CameraModel{}.intrinsics());
  }
  int with_depth = 0;
  for (size_t i = 0; i < detector->database().size(); ++i) {
    for (const cv::Point3f& point : detector->database().record(i)->local_features.points3d) {
      with_depth += std::isfinite(point.z) ? 1 : 0;
    }
  }
  return with_depth;
}

}  // namespace

TEST(LoopDetectorOnCorridor, DepthsAreTriangulatedOnlyOnceTheCameraMountIsKnown) {
  LoopDetector known(LoopDetectorOptions{}, makeDescriptorExtractor(DescriptorOptions{}));
  EXPECT_GT(triangulatedKeypoints(&known), 200);
  // A mount still awaited from tf: no guessed depths.
  LoopDetector awaiting(LoopDetectorOptions{}, makeDescriptorExtractor(DescriptorOptions{}));
  awaiting.setCameraMount(std::nullopt);
  EXPECT_FALSE(awaiting.cameraMount());
  EXPECT_EQ(triangulatedKeypoints(&awaiting), 0);
}

// Tracking lost in the second lap: the odometry comes back in a frame 40 m and a quarter turn away
// from its old one. The keyframes after it are a new session, so loops into the first lap are not
// refused by the odometry gate (which cannot compare two frames), depths are not triangulated
// across the two frames, and the jump is no distance travelled.
TEST(LoopDetectorOnCorridor, AfterTheOdometryIsReinitialisedLoopsJoinTheEarlierSession) {
  LoopDetector detector(LoopDetectorOptions{}, makeDescriptorExtractor(DescriptorOptions{}));
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 2.0;
  SequenceGenerator sequence(world, CameraModel{}, options);
  const size_t restart = sequence.size() * 13 / 20;  // 1.3 laps.
  const Eigen::Isometry3d new_frame_from_old =
      Eigen::Translation3d(40.0, -25.0, 0.0) *
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  std::map<uint64_t, SequenceFrame> truth_by_keyframe;
  std::optional<uint64_t> first_restarted;
  int loops_after = 0;
  int true_loops_after = 0;
  // What the detector publishes, as the pose graph node receives it (issue 68: the two sessions
  // are two chains of one graph, joined by the loops after the jump).
  PoseGraphSession graph(PoseGraphNodeOptions{}, MountLookup());
  std::vector<uint64_t> keyframe_ids;
  std::optional<uint64_t> first_loop_after_jump, joined_at;
  const Eigen::Isometry3d mount = LoopDetectorOptions{}.camera_mount.toPose().toIsometry();
  SequenceFrame frame;
  while (sequence.next(&frame)) {
    Pose odom = planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw);
    const bool restarted = frame.index >= restart;
    if (restarted) {
      odom = Pose::fromIsometry(new_frame_from_old * odom.toIsometry());
    }
    const FrameResult result =
        detector.process(frame.stamp, odom, frame.image, CameraModel{}.intrinsics());
    if (!result.admission.isKeyframe()) continue;
    const uint64_t id = result.admission.keyframe_id;
    truth_by_keyframe[id] = frame;
    ASSERT_TRUE(result.keyframe);
    EXPECT_EQ(detector.session(), restarted ? 1u : 0u) << frame.index;
    if (restarted && !first_restarted) {
      EXPECT_TRUE(result.admission.selection.reanchored);
      first_restarted = id;
    }
    GraphKeyframe keyframe;
    keyframe.id = id;
    keyframe.session = detector.session();
    keyframe.odometry = odom;
    keyframe.stamp_ns = static_cast<uint64_t>(frame.stamp * 1e9);
    std::vector<PoseGraphSession::Input> published{keyframe};
    keyframe_ids.push_back(id);
    if (result.keyframe->loop && result.keyframe->loop->relative_pose &&
        result.keyframe->loop->relative_pose->metric) {
      const RelativePose& relative = *result.keyframe->loop->relative_pose;
      GraphLoop loop;
      loop.query_session = result.keyframe->loop->query_session;
      loop.match_session = result.keyframe->loop->match_session;
      loop.has_relative_pose = loop.relative_pose_metric = true;
      loop.relative_pose_frame = PoseGraphNodeOptions{}.base_frame;
      LoopConstraint camera;
      camera.query_id = id;
      camera.match_id = result.keyframe->loop->match_id;
      camera.query_T_match.linear() = relative.rotation;
      camera.query_T_match.translation() = relative.translation;
      camera.covariance = relative.covariance;
      loop.constraint = loopInBaseFrame(camera, mount);
      published.emplace_back(loop);
    }
    if (restarted && published.size() > 1 && !first_loop_after_jump) first_loop_after_jump = id;
    graph.process(published);
    if (!joined_at && graph.graph().chainsJoinedToFirst() == 2) joined_at = id;
    if (!result.keyframe->loop || !restarted) continue;
    const AcceptedLoop& loop = *result.keyframe->loop;
    EXPECT_EQ(loop.query_session, 1u);
    EXPECT_EQ(loop.match_session, 0u);
    ++loops_after;
    true_loops_after += isTrueLoop(frame, truth_by_keyframe.at(loop.match_id)) ? 1 : 0;
  }
  ASSERT_TRUE(first_restarted);
  EXPECT_GE(loops_after, 3);
  EXPECT_EQ(true_loops_after, loops_after);

  const KeyframeDatabase& database = detector.database();
  size_t restart_index = 0;
  while (database.summary(restart_index).id < *first_restarted) ++restart_index;
  ASSERT_GT(restart_index, 0u);
  const KeyframeSummary& before = database.summary(restart_index - 1);
  const KeyframeSummary& after = database.summary(restart_index);
  EXPECT_EQ(after.session, 1u);
  EXPECT_EQ(after.path.metres, before.path.metres);  // The 47 m jump is not travelled.

  // The pose graph joined the two chains, and the keyframes after the jump lie within 0.1 m of
  // the truth with the rest (one similarity fit of every keyframe).
  EXPECT_EQ(graph.graph().chains(), 2u);
  EXPECT_EQ(graph.graph().chainsJoinedToFirst(), 2u) << graph.summary();
  std::vector<Pose> corrected, truth;
  for (const uint64_t id : keyframe_ids) {
    corrected.push_back(*graph.optimisedPose(0, id));
    const Pose2D& place = truth_by_keyframe.at(id).truth;
    truth.push_back(planarPose(place.x, place.y, place.yaw));
  }
  const std::vector<double> errors = eval::similarityAlignedErrors(corrected, truth);
  double worst_after_jump = 0.0;
  for (size_t k = 0; k < keyframe_ids.size(); ++k) {
    if (keyframe_ids[k] >= *first_restarted)
      worst_after_jump = std::max(worst_after_jump, errors[k]);
  }
  EXPECT_LT(worst_after_jump, 0.1) << graph.summary();
  ASSERT_TRUE(joined_at && first_loop_after_jump);
  std::printf(
      "jump at keyframe %llu; first metric loop after it at %llu, the chains joined at %llu; "
      "after the jump: largest keyframe error %.3f m (similarity fit of all); %s\n",
      static_cast<unsigned long long>(*first_restarted),
      static_cast<unsigned long long>(*first_loop_after_jump),
      static_cast<unsigned long long>(*joined_at), worst_after_jump, graph.summary().c_str());
}

namespace {

// Keypoints of a stored keyframe that got a triangulated depth.
int keypointsWithDepth(const KeyframeDatabase& database, size_t index) {
  int with_depth = 0;
  for (const cv::Point3f& point : database.record(index)->local_features.points3d) {
    with_depth += std::isfinite(point.z) ? 1 : 0;
  }
  return with_depth;
}

}  // namespace

// A small jump (1.5 m along the corridor, taken as a re-initialisation under a lower max_motion):
// across it the old keyframes' poses would give plausible depths, several times too far. The first
// keyframe of the new session has no neighbour in its own frame yet; the next ones triangulate as
// before.
TEST(LoopDetectorOnCorridor, DepthsAreNotTriangulatedAcrossAnOdometryRestart) {
  LoopDetectorOptions options;
  options.keyframe.max_motion = 1.0;
  LoopDetector detector(options, makeDescriptorExtractor(DescriptorOptions{}));
  SequenceOptions route;
  route.laps = 0.2;
  const CorridorWorld world;  // The generator keeps a reference.
  SequenceGenerator sequence(world, CameraModel{}, route);
  const size_t restart = sequence.size() / 2;
  SequenceFrame frame;
  while (sequence.next(&frame)) {
    const double ahead = frame.index >= restart ? 1.5 : 0.0;
    detector.process(frame.stamp, planarPose(frame.odom.x + ahead, frame.odom.y, frame.odom.yaw),
                     frame.image, CameraModel{}.intrinsics());
  }
  const KeyframeDatabase& database = detector.database();
  size_t first_restarted = 0;
  while (first_restarted < database.size() && database.summary(first_restarted).session == 0) {
    ++first_restarted;
  }
  ASSERT_GT(first_restarted, 2u);
  ASSERT_LT(first_restarted + 1, database.size());
  EXPECT_GT(keypointsWithDepth(database, first_restarted - 1), 0);
  EXPECT_EQ(keypointsWithDepth(database, first_restarted), 0)
      << "triangulated against the old odometry frame";
  EXPECT_GT(keypointsWithDepth(database, first_restarted + 1), 0);
}

namespace {

// Every third frame of one lap of the corridor: what an online user would train on.
std::vector<cv::Mat> firstLapImages() {
  SequenceOptions options;
  options.laps = 1.0;
  return sampleSequence(CorridorWorld{}, options, 3).images;
}

}  // namespace

// The two other methods, chosen by advanced/descriptor/type alone, through the same detector; each
// is trained on the first lap without labels (whitening fitted, broad autoencoder trained).
TEST(LoopDetectorOnCorridor, LearnedDescriptorsAtTheirThresholdsGiveOnlyTrueLoops) {
  const std::vector<cv::Mat> training = firstLapImages();
  const std::string folder = ::testing::TempDir();

  DescriptorOptions cnn;
  cnn.type = "cnn_pca";
  cnn.cnn.whitening = "none";
  const CnnGlobalDescriptor network(cnnGlobalOptions(cnn.cnn));
  const PcaWhitening whitening = eval::fitWhitening(
      network, training.size(), [&](size_t i) { return training[i]; }, 64, 1e-3);
  cnn.cnn.whitening = folder + "/corridor.whitening";
  whitening.save(cnn.cnn.whitening, network.featureIdentity());

  DescriptorOptions broad;
  broad.type = "broad";
  broad.broad.model = folder + "/corridor.broad";
  eval::trainBroad(BroadOptions{}, training.size(), [&](size_t i) {
    return training[i];
  }).save(broad.broad.model);

  for (const auto& [descriptor, min_score] : {std::pair{cnn, 0.6}, std::pair{broad, 0.8}}) {
    const RunSummary revisit = run(2.0, descriptor, min_score);
    EXPECT_GE(revisit.loops, 5) << descriptor.type;
    EXPECT_EQ(revisit.true_loops, revisit.loops)
        << descriptor.type << ": worst loop " << revisit.worst_loop_distance << " m";
    EXPECT_EQ(run(0.9, descriptor, min_score).loops, 0) << descriptor.type;
  }
}

// The broad autoencoder is trained before the run (lcd_train broad, as above): a model file that
// is not there yet is named with the command that writes it, and no detector starts without one.
TEST(LoopDetectorOnCorridor, BroadWithoutItsModelNamesTheTrainingCommand) {
  LoopDetectorOptions options;
  options.descriptor.type = "broad";
  options.descriptor.broad.model = ::testing::TempDir() + "/not_trained_yet.broad";
  std::filesystem::remove(options.descriptor.broad.model);
  EXPECT_EQ(options.validate(), "");  // The path is fine: the file is what is missing.
  try {
    makeDescriptorExtractor(options.descriptor);
    FAIL() << "an extractor without its model";
  } catch (const std::runtime_error& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("does not exist"), std::string::npos) << what;
    EXPECT_NE(
        what.find("lcd_train broad --bag YOUR_RUN.bag --output " + options.descriptor.broad.model),
        std::string::npos)
        << what;
  }
  EXPECT_THROW(LoopDetector(options, nullptr), std::invalid_argument);
}
