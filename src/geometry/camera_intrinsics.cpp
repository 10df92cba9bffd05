#include "landmark_loop_closure/geometry/camera_intrinsics.h"

#include <cmath>

namespace landmark_loop_closure {

bool CameraIntrinsics::valid() const {
  return std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy) &&
         fx > 0.0 && fy > 0.0 && image_size.width > 0 && image_size.height > 0;
}

CameraIntrinsics CameraIntrinsics::scaledTo(cv::Size size) const {
  if (image_size == size || image_size.area() == 0) return *this;
  const double sx = static_cast<double>(size.width) / image_size.width;
  const double sy = static_cast<double>(size.height) / image_size.height;
  // Pixel centres: a pixel's centre x + 0.5 scales, so the principal point shifts by half a pixel.
  CameraIntrinsics scaled;
  scaled.fx = fx * sx;
  scaled.fy = fy * sy;
  scaled.cx = (cx + 0.5) * sx - 0.5;
  scaled.cy = (cy + 0.5) * sy - 0.5;
  scaled.image_size = size;
  return scaled;
}

}  // namespace landmark_loop_closure
