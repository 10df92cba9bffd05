#pragma once

#include <vector>

#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {
namespace eval {

/// Position RMSE of an estimated trajectory against the true one (same length, pose by pose):
/// after moving the estimate so that its first pose lies on the truth's, and after the
/// similarity transform that fits it best, scale included (Umeyama; evo's -as). A drift in scale
/// shows as the difference between the two. All -1 for fewer than three poses.
struct TrajectoryError {
  double first_pose_rmse = -1.0;
  double similarity_rmse = -1.0;
  double scale = 1.0;  ///< Of that similarity transform.
};
TrajectoryError trajectoryError(const std::vector<Pose>& estimated,
                                const std::vector<Pose>& truth);

}  // namespace eval
}  // namespace landmark_loop_closure
