#include "landmark_loop_closure/geometry/camera_intrinsics.h"

#include <cmath>
#include <sstream>

namespace landmark_loop_closure {

std::string CameraIntrinsics::problem() const {
  const bool usable = std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
                      std::isfinite(cy) && image_size.width > 0 && image_size.height > 0 &&
                      fx > 0.0 && fy > 0.0 && fx <= 100.0 * image_size.width &&
                      fy <= 100.0 * image_size.width && cx >= 0.0 && cy >= 0.0 &&
                      cx < image_size.width && cy < image_size.height;
  if (usable) return "";  // The common case builds no text: valid() runs for every keyframe.
  std::ostringstream text;
  if (!(std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy))) {
    text << "K holds a non-finite value (fx " << fx << ", fy " << fy << ", cx " << cx << ", cy "
         << cy << ")";
  } else if (image_size.width <= 0 || image_size.height <= 0) {
    text << "image size " << image_size.width << "x" << image_size.height << " is empty";
  } else if (!(fx > 0.0) || !(fy > 0.0)) {
    text << "focal lengths fx " << fx << ", fy " << fy
         << " must be > 0 (K all zeros: no calibration)";
  } else if (fx > 100.0 * image_size.width || fy > 100.0 * image_size.width) {
    text << "focal lengths fx " << fx << ", fy " << fy << " are over 100 image widths";
  } else if (cx < 0.0 || cy < 0.0 || cx >= image_size.width || cy >= image_size.height) {
    text << "principal point (" << cx << ", " << cy << ") lies outside the " << image_size.width
         << "x" << image_size.height << " image";
  }
  return text.str();
}

std::string CameraIntrinsics::problemFor(cv::Size image) const {
  const std::string own = problem();
  if (!own.empty() || image.area() == 0) return own;
  const double ratio = static_cast<double>(image_size.width) / image_size.height;
  const double image_ratio = static_cast<double>(image.width) / image.height;
  if (std::abs(ratio / image_ratio - 1.0) > 0.02) {
    std::ostringstream text;
    text << "its size " << image_size.width << "x" << image_size.height
         << " has another aspect ratio than the " << image.width << "x" << image.height
         << " images";
    return text.str();
  }
  return "";
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
