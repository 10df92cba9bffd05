#pragma once

// The generated corridor seen through a real lens (plumb_bob distortion), for tests and benches
// that check what the detector makes of a distorted camera.

#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/geometry/camera_intrinsics.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace landmark_loop_closure {
namespace sim {

/// Each pixel of the distorted image looks along its undistorted ray into a wider pinhole render
/// (480x360: a corner's ray lies outside the 320x240 image), so the lens also widens the view.
/// Coefficients (k1, k2, p1, p2, k3) must keep the model monotonic over the image (k1 -0.3 with
/// k2 0.1 does).
class DistortedView {
 public:
  DistortedView(const CorridorWorld& world, const CameraModel& camera,
                const SequenceOptions& options, std::vector<double> plumb_bob);
  /// A frame of the sequence made with the same world and options, through the lens.
  cv::Mat render(const SequenceFrame& frame) const;
  /// The camera with its lens, as a calibrated driver's camera_info gives it.
  CameraIntrinsics intrinsics() const;
  const std::vector<double>& coefficients() const { return coefficients_; }

 private:
  CameraModel camera_;
  std::vector<double> coefficients_;
  SequenceGenerator wide_;
  cv::Mat map_x_;
  cv::Mat map_y_;
};

}  // namespace sim
}  // namespace landmark_loop_closure
