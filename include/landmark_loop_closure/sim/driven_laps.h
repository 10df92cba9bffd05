#pragma once

#include <cstdint>
#include <vector>

#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {
namespace sim {

/// Laps of a rectangle, a keyframe every `step` metres: true poses and odometry that
/// overestimates every turn and jitters each step, so later laps are drawn beside the first.
/// For the pose-graph backend's tests and benchmark (no images).
struct DrivenLapsOptions {
  int laps = 2;
  double length = 10.0;  ///< Metres, the rectangle's long side ...
  double width = 6.0;    ///< ... and its short side.
  double step = 0.5;
  double turn_error = 0.03;  ///< Each 90 degree turn is odometry's 90 * (1 + this).
  double step_noise_m = 0.005;
  uint32_t seed = 7;
};

struct DrivenLaps {
  std::vector<Pose> truth;
  std::vector<Pose> odometry;
  size_t keyframes_per_lap = 0;
};

DrivenLaps driveLaps(const DrivenLapsOptions& options);

}  // namespace sim
}  // namespace landmark_loop_closure
