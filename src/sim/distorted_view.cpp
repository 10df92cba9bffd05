#include "landmark_loop_closure/sim/distorted_view.h"

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {
namespace sim {

namespace {

CameraModel wideCamera() {
  CameraModel wide;
  wide.width = 480;
  wide.height = 360;
  return wide;
}

}  // namespace

DistortedView::DistortedView(const CorridorWorld& world, const CameraModel& camera,
                             const SequenceOptions& options, std::vector<double> plumb_bob)
    : camera_(camera), coefficients_(std::move(plumb_bob)), wide_(world, wideCamera(), options) {
  const CameraIntrinsics lens = intrinsics();
  std::vector<cv::Point2f> pixels;
  for (int v = 0; v < camera_.height; ++v) {
    for (int u = 0; u < camera_.width; ++u) pixels.emplace_back(u, v);
  }
  const std::vector<cv::Point2f> ideal = lens.idealPixels(pixels);
  const CameraIntrinsics wide = wideCamera().intrinsics();
  map_x_.create(camera_.height, camera_.width, CV_32FC1);
  map_y_.create(camera_.height, camera_.width, CV_32FC1);
  for (size_t i = 0; i < ideal.size(); ++i) {
    const int v = static_cast<int>(i) / camera_.width;
    const int u = static_cast<int>(i) % camera_.width;
    map_x_.at<float>(v, u) = static_cast<float>(ideal[i].x - lens.cx + wide.cx);
    map_y_.at<float>(v, u) = static_cast<float>(ideal[i].y - lens.cy + wide.cy);
  }
}

cv::Mat DistortedView::render(const SequenceFrame& frame) const {
  cv::Mat distorted;
  cv::remap(wide_.render(frame), distorted, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return distorted;
}

CameraIntrinsics DistortedView::intrinsics() const {
  CameraIntrinsics intrinsics = camera_.intrinsics();
  intrinsics.setLens("plumb_bob", coefficients_);
  return intrinsics;
}

}  // namespace sim
}  // namespace landmark_loop_closure
