#include "landmark_loop_closure/geometry/camera_intrinsics.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace landmark_loop_closure {

namespace {

CalibrationProblem problemOf(const char* cause, const std::ostringstream& text) {
  return {cause, text.str()};
}

}  // namespace

std::optional<CalibrationProblem> CameraIntrinsics::check() const {
  const double width = image_size.width;
  const double height = image_size.height;
  const bool finite =
      std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy);
  const bool usable =
      finite && width > 0 && height > 0 && fx >= kMinFocalWidths * width &&
      fy >= kMinFocalWidths * width && fx <= kMaxFocalWidths * width &&
      fy <= kMaxFocalWidths * width && fy <= kMaxPixelAspect * fx && fx <= kMaxPixelAspect * fy &&
      cx >= kPrincipalPointMargin * width && cx <= (1.0 - kPrincipalPointMargin) * width &&
      cy >= kPrincipalPointMargin * height && cy <= (1.0 - kPrincipalPointMargin) * height;
  if (usable) return std::nullopt;  // The common case builds no text: it runs for every keyframe.
  std::ostringstream text;
  if (!finite) {
    text << "K holds a non-finite value (fx " << fx << ", fy " << fy << ", cx " << cx << ", cy "
         << cy << ")";
    return problemOf("non_finite", text);
  }
  if (fx == 0.0 && fy == 0.0 && cx == 0.0 && cy == 0.0) {
    text << "K is all zeros: the camera driver has no calibration";
    return problemOf("no_calibration", text);
  }
  if (width <= 0 || height <= 0) {
    text << "its image size " << image_size.width << "x" << image_size.height << " is empty";
    return problemOf("empty_size", text);
  }
  if (!(fx > 0.0) || !(fy > 0.0)) {
    text << "focal lengths fx " << fx << ", fy " << fy << " must both be positive";
    return problemOf("focal_not_positive", text);
  }
  if (std::min(fx, fy) < kMinFocalWidths * width || std::max(fx, fy) > kMaxFocalWidths * width) {
    text << "focal lengths fx " << fx << ", fy " << fy << " are not between " << kMinFocalWidths
         << " and " << kMaxFocalWidths << " image widths (" << kMinFocalWidths * width << " to "
         << kMaxFocalWidths * width << " px for " << image_size.width << " px)";
    return problemOf("focal_implausible", text);
  }
  if (fy > kMaxPixelAspect * fx || fx > kMaxPixelAspect * fy) {
    text << "focal lengths fx " << fx << ", fy " << fy << " differ by more than a factor of "
         << kMaxPixelAspect;
    return problemOf("pixel_aspect", text);
  }
  text << "principal point (" << cx << ", " << cy << ") is not in the middle "
       << 100.0 * (1.0 - 2.0 * kPrincipalPointMargin) << " % of the " << image_size.width << "x"
       << image_size.height << " image";
  return problemOf("principal_point", text);
}

std::optional<CalibrationProblem> CameraIntrinsics::checkFor(cv::Size image) const {
  std::optional<CalibrationProblem> own = check();
  if (own || image.area() == 0) return own;
  const double ratio = static_cast<double>(image_size.width) / image_size.height;
  const double image_ratio = static_cast<double>(image.width) / image.height;
  if (std::abs(ratio / image_ratio - 1.0) <= 0.02) return std::nullopt;
  std::ostringstream text;
  text << "its size " << image_size.width << "x" << image_size.height
       << " has another aspect ratio than the " << image.width << "x" << image.height << " images";
  return problemOf("aspect_ratio", text);
}

std::string CameraIntrinsics::problem() const {
  const std::optional<CalibrationProblem> found = check();
  return found ? found->text : "";
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
