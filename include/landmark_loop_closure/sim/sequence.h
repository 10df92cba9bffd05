#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/geometry/pose.h"
#include "landmark_loop_closure/sim/corridor_world.h"

namespace landmark_loop_closure {
namespace sim {

/// A camera driven around the corridor: ground-truth poses, odometry that drifts, images.
/// From the second lap on, the route is shifted sideways and the lighting changes, so revisits
/// are real loops seen from another viewpoint in other light.
struct SequenceOptions {
  double speed = 1.0;            ///< Metres per second along the route.
  double rate = 10.0;            ///< Frames per second.
  double laps = 2.0;             ///< Route length in laps (fractions allowed).
  double start_stamp = 1.0;      ///< Stamp of the first frame, seconds.
  double revisit_lateral = 0.2;  ///< Sideways offset of laps after the first, metres.
  Lighting first_lap_lighting{1.0, 0.0, 2.0};
  Lighting revisit_lighting{0.7, 20.0, 3.0};
  double odom_scale_error = 0.02;           ///< Odometry overestimates distance by this fraction.
  double odom_yaw_drift_per_metre = 0.004;  ///< Radians of heading error gained per metre.
  uint32_t seed = 7;
};

struct SequenceFrame {
  size_t index = 0;
  double stamp = 0.0;
  int lap = 0;
  Pose2D truth;   ///< In the world frame.
  Pose2D odom;    ///< Integrated with drift, starting at the first truth pose.
  cv::Mat image;  ///< Empty when rendering was not asked for.
};

class SequenceGenerator {
 public:
  SequenceGenerator(const CorridorWorld& world, const CameraModel& camera,
                    const SequenceOptions& options);

  size_t size() const { return frame_count_; }
  /// Produces the next frame; false after the last one. Images only when `render` is true.
  bool next(SequenceFrame* frame, bool render = true);
  /// The image of a frame produced by next(), for callers that render only some frames.
  cv::Mat render(const SequenceFrame& frame) const;

 private:
  Pose2D truthAt(size_t index, int* lap) const;

  const CorridorWorld& world_;
  CameraModel camera_;
  SequenceOptions options_;
  size_t frame_count_ = 0;
  size_t next_index_ = 0;
  Pose2D previous_truth_;
  Pose2D odom_;
};

/// Every `every`-th frame of a generated sequence, rendered, with its true pose (the evaluation's
/// corridor: at 1 m/s and 10 Hz, every 3rd frame is one image every 0.3 m, like the keyframes).
struct SampledSequence {
  std::vector<cv::Mat> images;
  std::vector<Pose> truth;
  std::vector<double> stamps;
};
SampledSequence sampleSequence(const CorridorWorld& world, const SequenceOptions& options,
                               size_t every);

}  // namespace sim
}  // namespace landmark_loop_closure
