// The robots protocol (issue 68): each run is another robot, with a detector and a map of its
// own; from the second on, each robot keeps the earlier robots' shared rows (FleetMatcher),
// searches each of its keyframes in them, fetches the evidence of a chained candidate from the
// robot that stored it and checks it, as the node's fleet link does. The loops judged are those
// between robots.
#include <chrono>
#include <memory>
#include <vector>

#include "landmark_loop_closure/eval/detector_evaluation.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

struct Robot {
  std::unique_ptr<LoopDetector> detector;
  std::unique_ptr<FleetMatcher> matcher;  ///< The earlier robots' rows.
  std::map<uint64_t, size_t> frame_of;    ///< Frame index of each keyframe, by id.
  CameraIntrinsics intrinsics;            ///< The latest frame's.
};

}  // namespace

DetectorEvaluation evaluateRobots(const LoopDetectorOptions& options,
                                  std::shared_ptr<const DescriptorExtractor> extractor,
                                  const FramePlayer& play, const SamePlace& same_place,
                                  const FleetOptions& fleet) {
  const std::string problems = options.validate() + fleet.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  DetectorEvaluation evaluation;
  evaluation.recall_at_100_precision = -1.0;  // The fleet's decision is not swept.
  DetectorPass& pass = evaluation.configured;
  pass.min_score = fleet.min_score;
  const GeometricVerifier verifier(options.verification);
  const PlaceCheckSettings settings{options.verification, options.appearance, options.metric_pose};
  const Eigen::Isometry3d mount = options.camera_mount.toPose().toIsometry();
  std::vector<Robot> robots;
  std::vector<SharedKeyframe> shared;  // Every robot's rows, as they were announced.
  const auto robotOfMap = [&robots](uint64_t map_id) -> Robot* {
    for (Robot& robot : robots) {
      if (robot.detector->map().mapId() == map_id) return &robot;
    }
    return nullptr;
  };

  play([&](size_t index, const DetectorFrame& frame) {
    ++evaluation.frames;
    if (robots.empty() || frame.new_run) {
      Robot robot;
      robot.detector = std::make_unique<LoopDetector>(options, extractor);
      robot.detector->map().announceKeyframes(true);
      robot.matcher = std::make_unique<FleetMatcher>(fleet, robot.detector->descriptorIdentity(),
                                                     robot.detector->database().globalDimension());
      for (const SharedKeyframe& row : shared) {
        robot.matcher->addRow(row, 0.0, robot.detector->map().mapId());
      }
      robots.push_back(std::move(robot));
    }
    Robot& robot = robots.back();
    robot.intrinsics = frame.intrinsics;
    const auto start = std::chrono::steady_clock::now();
    const FrameResult result =
        robot.detector->process(frame.stamp, frame.pose, frame.image, frame.intrinsics);
    if (result.admission.error || (result.keyframe && result.keyframe->error)) {
      ++evaluation.refused_frames;
      return;
    }
    if (result.keyframe) {
      ++evaluation.keyframes;
      robot.frame_of[result.admission.keyframe_id] = index;
    }
    for (const AnnouncedKeyframe& announced : robot.detector->map().takeAnnounced()) {
      const uint64_t id = announced.summary.id;
      const std::optional<SharedKeyframe> row =
          sharedKeyframeOf(*robot.detector, id, "robot " + std::to_string(robots.size()), "odom");
      if (!row) continue;
      shared.push_back(*row);
      if (robots.size() < 2) continue;
      const size_t query_frame = robot.frame_of.at(id);
      bool revisit = false;
      for (size_t other = 0; other + 1 < robots.size() && !revisit; ++other) {
        for (const auto& [other_id, other_frame] : robots[other].frame_of) {
          if (same_place(query_frame, other_frame)) {
            revisit = true;
            break;
          }
        }
      }
      evaluation.revisits += revisit ? 1 : 0;
      const std::optional<FleetCandidate> candidate = robot.matcher->query(*row);
      if (!candidate) {
        ++pass.refused["no_chained_candidate"];
        continue;
      }
      Robot* owner = robotOfMap(candidate->match.map_id);
      const std::shared_ptr<const KeyframeRecord> query = robot.detector->database().findRecord(id);
      const std::optional<KeyframeEvidence> evidence =
          owner ? evidenceOf(*owner->detector, candidate->match.id, owner->intrinsics)
                : std::nullopt;
      if (!query || !evidence) {
        ++pass.refused["unreadable"];
        continue;
      }
      const PlaceCheck check =
          checkFleetCandidate(verifier, settings, query->local_features, robot.intrinsics,
                              *evidence, thumbnailCellsOf(*robot.detector, query->thumbnail),
                              thumbnailCellsOf(*owner->detector, evidence->thumbnail),
                              fleet.appearance_confirms, candidate->false_alarms);
      if (!check.accepted) {
        ++pass.refused["place_not_confirmed"];
        continue;
      }
      PublishedLoop loop;
      loop.query_id = id;
      loop.match_id = candidate->match.id;
      loop.query_frame = query_frame;
      loop.match_frame = owner->frame_of.at(candidate->match.id);
      loop.score = candidate->score;
      loop.verified = check.verification.has_value();
      loop.correct = same_place(loop.query_frame, loop.match_frame);
      if (check.relative_pose && check.relative_pose->metric) {
        LoopConstraint camera;
        camera.query_id = id;
        camera.match_id = candidate->match.id;
        camera.query_T_match.linear() = check.relative_pose->rotation;
        camera.query_T_match.translation() = check.relative_pose->translation;
        camera.covariance = check.relative_pose->covariance;
        loop.metric_pose = loopInBaseFrame(camera, mount);
      }
      pass.true_loops += loop.correct ? 1 : 0;
      pass.loops.push_back(loop);
    }
    if (result.keyframe) {
      pass.keyframe_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count());
    }
  });
  pass.precision =
      pass.loops.empty() ? 1.0 : static_cast<double>(pass.true_loops) / pass.loops.size();
  pass.recall =
      evaluation.revisits > 0 ? static_cast<double>(pass.true_loops) / evaluation.revisits : 0.0;
  evaluation.keyframe_ms = percentiles(pass.keyframe_ms);
  return evaluation;
}

}  // namespace eval
}  // namespace landmark_loop_closure
