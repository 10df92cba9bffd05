#pragma once

// A real route's loops for the pose graph: KITTI odometry's ground-truth poses taken as keyframes
// every `keyframe_step_m`, odometry made to drift as the demo's does (a scale error and a heading
// error per metre, with a little noise), every revisit closing a loop with the true relative pose
// (noisy, with its covariance), and a share of loops replaced by wrong ones as loop_injector does.
#include <cstdint>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {
namespace tools {

struct KittiRouteOptions {
  double keyframe_step_m = 2.0;
  double scale_error = 0.02;           ///< Odometry's distances are (1 + this) times the true.
  double heading_error_per_m = 0.004;  ///< Radians about the vertical added per metre ...
  /// ... a rate that wanders by this much (rad/m) per square-root metre (a random walk): a
  /// drift that is not steady.
  double heading_error_walk = 0.0;
  /// Each step's turn is odometry's (1 + this) times the true one (an error per radian turned).
  double turn_error = 0.0;
  double step_noise_m = 0.01;    ///< Per keyframe step, each axis.
  double loop_radius_m = 3.0;    ///< A keyframe this close to an older one revisits it ...
  size_t loop_min_gap = 50;      ///< ... at least this many keyframes older.
  double loop_noise_m = 0.05;    ///< Noise on the loop's relative translation, each axis ...
  double loop_noise_rad = 0.01;  ///< ... and rotation.
  double wrong_fraction = 0.05;  ///< Loops whose match is replaced by a random older one.
  size_t wrong_min_gap = 20;     ///< The wrong match is at least this many ids away.
  uint32_t seed = 1;
};

struct KittiRoute {
  std::vector<Pose> truth;            ///< By keyframe id.
  std::vector<Pose> odometry;         ///< By keyframe id.
  std::vector<LoopConstraint> loops;  ///< In query order.
  std::vector<bool> wrong;            ///< Per loop: injected.
};

/// `camera_poses`: KITTI's world_T_camera (camera x right, y down, z forward).
KittiRoute kittiRoute(const std::vector<Pose>& camera_poses, const KittiRouteOptions& options);

}  // namespace tools
}  // namespace landmark_loop_closure
