#pragma once

// How fuzz_pose_graph_session reads its input as what the pose_graph node receives: keyframes of
// two maps with stamps that go back and forth, loops of any map, run and frame, in batches; tests
// replay the kept inputs with it.

#include <string>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "pose_graph_input.h"

namespace landmark_loop_closure {
namespace fuzz {

/// The frames a loop may name: the base, a camera the mount knows, one tf does not know, none.
inline std::optional<Eigen::Isometry3d> cameraMount(const std::string& frame,
                                                    std::string* problem) {
  if (frame == "camera") {
    return Eigen::Translation3d(0.2, 0.0, 0.5) *
           Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX());
  }
  *problem = "no tf base_link -> '" + frame + "'";
  return std::nullopt;
}

/// Byte 0-2 set the graph's options (confirmations, drift estimate, iterations); then operations
/// until the input ends (at most 96): a keyframe (id step, map 1 or 2, stamp step -8..+7 s,
/// position, quaternion as a message carries it), a loop (its map, runs, whether it has a pose
/// and a metric one, its frame, then as fuzz_pose_graph reads one) or the batch so far processed;
/// the rest processed at the end. False when an invariant breaks: an estimate not finite, the
/// graph's loops and the session's own list of them of different lengths.
inline bool replayPoseGraphSessionInput(const uint8_t* data, size_t size) {
  ByteStream in(data, size);
  PoseGraphNodeOptions options;
  options.graph.loop_confirmations = in.byte() % 3;
  options.graph.heading_drift_prior_sd_per_m = (in.byte() % 2) ? 0.01 : 0.0;
  options.graph.max_iterations = 1 + in.byte() % 20;
  PoseGraphSession session(options, cameraMount);
  const auto holds = [&session] {
    session.pathsPublished();
    return session.graphLoops().size() == session.graph().loopVerdicts().size() &&
           session.stampsNs().size() == session.graph().keyframes() &&
           estimatesFinite(session.graph()) && !session.summary().empty();
  };
  static const char* const kFrames[] = {"base_link", "camera", "rear_camera", ""};
  std::vector<PoseGraphSession::Input> batch;
  uint64_t next_id = 0;
  uint64_t stamp_s = 1000;
  for (int operations = 0; operations < 96 && !in.empty(); ++operations) {
    const uint8_t kind = in.byte() % 4;
    if (kind <= 1) {
      GraphKeyframe keyframe;
      next_id += in.byte() % 4;  // 0 repeats the last id: refused.
      keyframe.id = next_id;
      const uint8_t map_and_session = in.byte();
      keyframe.map_id = 1 + map_and_session % 2;
      keyframe.session = (map_and_session >> 1) & 1;
      stamp_s += static_cast<uint64_t>(static_cast<int64_t>(in.byte() % 16) - 8);
      keyframe.stamp_ns = stamp_s * 1000000000ull;
      keyframe.odometry.position = Eigen::Vector3d(in.number(), in.number(), in.number());
      keyframe.odometry.orientation = quaternion(&in);
      keyframe.odometry_frame = "odom";
      batch.emplace_back(keyframe);
    } else if (kind == 2) {
      GraphLoop loop;
      const uint8_t flags = in.byte();
      loop.map_id = 1 + (flags & 1);
      loop.query_session = (flags >> 1) & 1;
      loop.match_session = (flags >> 2) & 1;
      loop.has_relative_pose = (flags >> 3) & 1;
      loop.relative_pose_metric = (flags >> 4) & 1;
      loop.relative_pose_frame = kFrames[(flags >> 5) & 3];
      // Ids a little beyond the last keyframe too: such a loop waits for its keyframe.
      loop.constraint = readLoop(&in, next_id + 16);
      batch.emplace_back(loop);
    } else {
      session.process(batch);
      batch.clear();
      if (!holds()) return false;
    }
  }
  session.process(batch);
  return holds();
}

}  // namespace fuzz
}  // namespace landmark_loop_closure
