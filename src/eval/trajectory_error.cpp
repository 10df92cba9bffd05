#include "landmark_loop_closure/eval/trajectory_error.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace landmark_loop_closure {
namespace eval {

TrajectoryError trajectoryError(const std::vector<Pose>& estimated,
                                const std::vector<Pose>& truth) {
  TrajectoryError error;
  const size_t count = std::min(estimated.size(), truth.size());
  if (count < 3) {
    error.first_pose_rmse = error.similarity_rmse = -1.0;
    return error;
  }
  const Eigen::Isometry3d align = truth[0].toIsometry() * estimated[0].toIsometry().inverse();
  Eigen::Matrix3Xd from(3, count);
  Eigen::Matrix3Xd to(3, count);
  double first = 0.0;
  for (size_t i = 0; i < count; ++i) {
    const auto column = static_cast<Eigen::Index>(i);
    from.col(column) = estimated[i].position;
    to.col(column) = truth[i].position;
    first += (align * estimated[i].position - truth[i].position).squaredNorm();
  }
  const Eigen::Matrix4d similarity = Eigen::umeyama(from, to, true);
  const Eigen::Matrix3Xd moved =
      (similarity.topLeftCorner<3, 3>() * from).colwise() + similarity.topRightCorner<3, 1>();
  error.first_pose_rmse = std::sqrt(first / static_cast<double>(count));
  error.similarity_rmse =
      std::sqrt((moved - to).colwise().squaredNorm().sum() / static_cast<double>(count));
  error.scale = similarity.topLeftCorner<3, 3>().col(0).norm();
  return error;
}

std::vector<double> similarityAlignedErrors(const std::vector<Pose>& estimated,
                                            const std::vector<Pose>& truth) {
  const size_t count = std::min(estimated.size(), truth.size());
  if (count < 3) return {};
  Eigen::Matrix3Xd from(3, count);
  Eigen::Matrix3Xd to(3, count);
  for (size_t i = 0; i < count; ++i) {
    from.col(static_cast<Eigen::Index>(i)) = estimated[i].position;
    to.col(static_cast<Eigen::Index>(i)) = truth[i].position;
  }
  const Eigen::Matrix4d similarity = Eigen::umeyama(from, to, true);
  const Eigen::Matrix3Xd moved =
      (similarity.topLeftCorner<3, 3>() * from).colwise() + similarity.topRightCorner<3, 1>();
  std::vector<double> errors(count);
  for (size_t i = 0; i < count; ++i) {
    errors[i] =
        (moved.col(static_cast<Eigen::Index>(i)) - to.col(static_cast<Eigen::Index>(i))).norm();
  }
  return errors;
}

PoseGraphReplay replayIntoPoseGraph(const DetectorEvaluation& evaluation,
                                    const PoseGraphOptions& options) {
  PoseGraphReplay replay;
  PoseGraphNodeOptions node_options;
  node_options.graph = options;
  // The loops are in the base frame already (metric_pose): no mount to look up.
  PoseGraphSession session(node_options, MountLookup());
  std::vector<const PublishedLoop*> loops;
  for (const PublishedLoop& loop : evaluation.configured.loops) {
    if (loop.metric_pose) loops.push_back(&loop);
  }
  constexpr uint64_t kSecond = 1000000000ull;
  const auto sessionOf = [&evaluation](uint64_t id) -> uint32_t {
    return id < evaluation.keyframe_sessions.size() ? evaluation.keyframe_sessions[id] : 0;
  };
  size_t next = 0;
  for (uint64_t id = 0; id < evaluation.keyframe_poses.size(); ++id) {
    GraphKeyframe keyframe;
    keyframe.id = id;
    keyframe.session = sessionOf(id);
    keyframe.odometry = evaluation.keyframe_poses[id];
    keyframe.stamp_ns = (id + 1) * kSecond;
    keyframe.odometry_frame = "odom";
    std::vector<PoseGraphSession::Input> batch{keyframe};
    for (; next < loops.size() && loops[next]->query_id == id; ++next) {
      GraphLoop loop;
      loop.has_relative_pose = loop.relative_pose_metric = true;
      loop.relative_pose_frame = node_options.base_frame;
      loop.constraint = *loops[next]->metric_pose;
      loop.query_session = sessionOf(loop.constraint.query_id);
      loop.match_session = sessionOf(loop.constraint.match_id);
      batch.emplace_back(loop);
      ++replay.metric_loops;
    }
    session.process(batch);
  }
  // Every loop of the one map in the base frame enters the graph (both its keyframes came
  // before it): its loop order is `loops`'.
  const PoseGraph& graph = session.graph();
  const std::vector<LoopVerdict>& verdicts = graph.loopVerdicts();
  for (size_t k = 0; k < verdicts.size(); ++k) {
    const bool accepted = verdicts[k].decision == LoopDecision::kAccepted;
    if (sessionOf(loops[k]->query_id) != sessionOf(loops[k]->match_id)) {
      ++replay.cross_session_loops;
      replay.cross_session_loops_accepted += accepted ? 1 : 0;
    }
    if (accepted) continue;
    ++replay.refused_loops;
    replay.refused_true_loops += loops[k]->correct ? 1 : 0;
  }
  replay.heading_drift_per_m = graph.headingDriftPerMetre();
  replay.chains = graph.chains();
  replay.chains_joined = graph.chainsJoinedToFirst();
  for (uint64_t id = 0; id < evaluation.keyframe_poses.size(); ++id) {
    replay.corrected.push_back(
        session.optimisedPose(0, id).value_or(evaluation.keyframe_poses[id]));
  }
  return replay;
}

}  // namespace eval
}  // namespace landmark_loop_closure
