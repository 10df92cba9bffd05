#pragma once

// Keyframes along a straight line, true loops between them and the options the pose graph tests
// share (the session's tests and its runtime's).
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph_session.h"

namespace landmark_loop_closure {
namespace pose_graph_fixtures {

inline constexpr uint64_t kMap = 7;
inline constexpr uint64_t kSecond = 1000000000ull;

/// Along x, 1 m a keyframe, one keyframe a second.
inline GraphKeyframe keyframeAt(uint64_t id, uint64_t map_id = kMap, uint64_t stamp_ns = 0) {
  GraphKeyframe keyframe;
  keyframe.id = id;
  keyframe.map_id = map_id;
  keyframe.odometry.position = Eigen::Vector3d(static_cast<double>(id), 0.0, 0.0);
  keyframe.stamp_ns = stamp_ns > 0 ? stamp_ns : (id + 1) * kSecond;
  keyframe.odometry_frame = "odom";
  return keyframe;
}

/// A metric loop in the base frame whose relative pose is the odometry's own (a true one).
inline GraphLoop loopBetween(uint64_t query, uint64_t match) {
  GraphLoop loop;
  loop.map_id = kMap;
  loop.constraint.query_id = query;
  loop.constraint.match_id = match;
  loop.query_stamp_ns = (query + 1) * kSecond;
  loop.match_stamp_ns = (match + 1) * kSecond;
  loop.has_relative_pose = true;
  loop.relative_pose_metric = true;
  loop.relative_pose_frame = "base_link";
  loop.constraint.query_T_match.translation() =
      Eigen::Vector3d(static_cast<double>(match) - static_cast<double>(query), 0.0, 0.0);
  loop.constraint.covariance = 1e-4 * Eigen::Matrix<double, 6, 6>::Identity();
  return loop;
}

/// Knows "camera" only (0.2 m ahead of the base); says why for any other frame.
inline std::optional<Eigen::Isometry3d> cameraOnly(const std::string& frame, std::string* problem) {
  if (frame == "camera") return Eigen::Isometry3d(Eigen::Translation3d(0.2, 0.0, 0.0));
  *problem = "no tf base_link -> '" + frame + "'";
  return std::nullopt;
}

inline PoseGraphNodeOptions eachLoopOnItsOwn() {
  PoseGraphNodeOptions options;
  options.graph.loop_confirmations = 0;
  return options;
}

inline std::vector<PoseGraphSession::Input> keyframes(uint64_t first, uint64_t end) {
  std::vector<PoseGraphSession::Input> inputs;
  for (uint64_t id = first; id < end; ++id) inputs.emplace_back(keyframeAt(id));
  return inputs;
}

inline bool hasNotice(const GraphStep& step, GraphNotice::Kind kind, const std::string& part) {
  return std::any_of(step.notices.begin(), step.notices.end(), [&](const GraphNotice& notice) {
    return notice.kind == kind && notice.text.find(part) != std::string::npos;
  });
}

/// Keyframes 0-11, then a loop saying the odometry overestimated the 10 m from 1 to 11 by 0.3 m:
/// the graph moves the last keyframes back. True when that loop was accepted.
inline bool correctTwelveKeyframes(PoseGraphSession* session) {
  session->process(keyframes(0, 12));
  GraphLoop shorter = loopBetween(11, 1);
  shorter.constraint.query_T_match.translation().x() += 0.3;
  const GraphStep step = session->process({shorter});
  return step.verdicts.size() == 1 && step.verdicts[0].decision == "accepted";
}

}  // namespace pose_graph_fixtures
}  // namespace landmark_loop_closure
