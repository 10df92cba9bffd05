#pragma once

// How fuzz_pose_graph reads its input as a sequence of keyframes, loops and optimisations; tests
// replay the kept inputs with it.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>

#include "byte_stream.h"
#include "landmark_loop_closure/backend/pose_graph.h"

namespace landmark_loop_closure {
namespace fuzz {

inline bool finite(const Pose& pose) {
  return pose.position.allFinite() && pose.orientation.coeffs().allFinite();
}

/// Ids below `span`, a relative pose (rotation as a message carries it, not normalised: one that
/// is not a rotation must be refused) and a covariance: diagonal, full or one variance.
inline LoopConstraint readLoop(ByteStream* in, uint64_t span) {
  LoopConstraint loop;
  loop.query_id = in->byte() % span;
  loop.match_id = in->byte() % span;
  const Eigen::Vector3d translation(in->number(), in->number(), in->number());
  const Eigen::Quaterniond rotation = quaternion(in);
  loop.query_T_match.setIdentity();
  loop.query_T_match.translate(translation);
  loop.query_T_match.linear() = scaledRotationMatrix(rotation);
  const uint8_t covariance_kind = in->byte() % 3;
  if (covariance_kind == 0) {
    for (int k = 0; k < 6; ++k) loop.covariance(k, k) = in->number();
  } else if (covariance_kind == 1) {
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) loop.covariance(r, c) = in->number();
    }
  } else {
    const double variance = in->number();
    loop.covariance = Eigen::Matrix<double, 6, 6>::Identity() * variance;
  }
  return loop;
}

/// Every estimate the graph hands out is finite.
inline bool estimatesFinite(const PoseGraph& graph) {
  for (const uint64_t id : graph.ids()) {
    const std::optional<Pose> pose = graph.optimisedPose(id);
    if (!pose || !finite(*pose)) return false;
  }
  return graph.mapFromOdometry().matrix().allFinite();
}

/// Byte 0-2 set the options that change the graph's paths (confirmations, drift estimate,
/// iterations); then operations until the input ends (at most 64): a keyframe (id step, position,
/// quaternion as a message carries it), a loop (ids, relative pose, covariance: diagonal, full or
/// one variance) or an optimisation; one last optimisation. False when an estimate is not finite.
inline bool replayPoseGraphInput(const uint8_t* data, size_t size) {
  ByteStream in(data, size);
  PoseGraphOptions options;
  options.loop_confirmations = in.byte() % 3;
  options.heading_drift_prior_sd_per_m = (in.byte() % 2) ? 0.01 : 0.0;
  options.max_iterations = 1 + in.byte() % 20;
  PoseGraph graph(options);
  uint64_t next_id = 0;
  for (int operations = 0; operations < 64 && !in.empty(); ++operations) {
    switch (in.byte() % 4) {
      case 0:
      case 1: {
        next_id += in.byte() % 4;  // 0 repeats the last id: refused.
        Pose pose;
        pose.position = Eigen::Vector3d(in.number(), in.number(), in.number());
        pose.orientation = quaternion(&in);
        graph.addKeyframe(next_id, pose);
        break;
      }
      case 2:
        graph.addLoop(readLoop(&in, next_id + 2));
        break;
      default:
        graph.optimise();
        break;
    }
  }
  graph.optimise();
  return estimatesFinite(graph);
}

}  // namespace fuzz
}  // namespace landmark_loop_closure
