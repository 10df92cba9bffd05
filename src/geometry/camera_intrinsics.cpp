#include "landmark_loop_closure/geometry/camera_intrinsics.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/calib3d.hpp>

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
  if (usable) {
    // The usable cases build no text: this runs for every image.
    if (distortion == LensDistortion::kNone) return std::nullopt;
    if (distortion == LensDistortion::kUnsupported) {
      std::ostringstream text;
      text << "distortion model \"" << distortion_name
           << "\" is not one the keypoints can be corrected for (plumb_bob, rational_polynomial, "
              "equidistant)";
      return problemOf("distortion_model", text);
    }
    const size_t wanted = distortion == LensDistortion::kRationalPolynomial ? 8
                          : distortion == LensDistortion::kEquidistant      ? 4
                                                                            : 5;
    const bool count_ok = coefficients.size() == wanted ||
                          (distortion == LensDistortion::kPlumbBob && coefficients.size() == 4);
    bool coefficients_finite = true;
    for (const double value : coefficients) coefficients_finite &= std::isfinite(value);
    if (count_ok && coefficients_finite) return std::nullopt;
    std::ostringstream text;
    text << "D has " << coefficients.size() << " values"
         << (coefficients_finite ? "" : ", not all finite") << ": " << distortion_name << " needs "
         << wanted;
    return problemOf("distortion_coefficients", text);
  }
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
  // The lens model, on normalised coordinates, stays as it is.
  CameraIntrinsics scaled = *this;
  scaled.fx = fx * sx;
  scaled.fy = fy * sy;
  scaled.cx = (cx + 0.5) * sx - 0.5;
  scaled.cy = (cy + 0.5) * sy - 0.5;
  scaled.image_size = size;
  return scaled;
}

LensDistortion lensDistortionNamed(const std::string& name) {
  if (name == "plumb_bob") return LensDistortion::kPlumbBob;
  if (name == "rational_polynomial") return LensDistortion::kRationalPolynomial;
  if (name == "equidistant") return LensDistortion::kEquidistant;
  if (name.empty() || name == "none") return LensDistortion::kNone;
  return LensDistortion::kUnsupported;
}

void CameraIntrinsics::setLens(const std::string& model, std::vector<double> d) {
  distortion_name = model;
  coefficients = std::move(d);
  distortion = lensDistortionNamed(model);
  if (std::all_of(coefficients.begin(), coefficients.end(), [](double v) { return v == 0.0; })) {
    distortion = LensDistortion::kNone;
    coefficients.clear();
  }
}

bool CameraIntrinsics::distorted() const {
  if (distortion == LensDistortion::kNone || distortion == LensDistortion::kUnsupported) {
    return false;
  }
  for (const double value : coefficients) {
    if (value != 0.0) return true;
  }
  return false;
}

std::vector<cv::Point2f> CameraIntrinsics::idealPixels(
    const std::vector<cv::Point2f>& pixels) const {
  if (!distorted() || pixels.empty()) return pixels;
  const cv::Mat k(matrix());
  std::vector<cv::Point2f> ideal;
  if (distortion == LensDistortion::kEquidistant) {
    cv::fisheye::undistortPoints(pixels, ideal, k, coefficients, cv::noArray(), k);
  } else {
    // Strong lenses (k1 about -0.3) need more than the default five iterations at the corners.
    cv::undistortPoints(
        pixels, ideal, k, coefficients, cv::noArray(), k,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-9));
  }
  return ideal;
}

std::vector<cv::Point2f> CameraIntrinsics::imagePixels(
    const std::vector<cv::Point2f>& ideal) const {
  if (!distorted() || ideal.empty()) return ideal;
  std::vector<cv::Point3f> rays;
  rays.reserve(ideal.size());
  for (const cv::Point2f& p : ideal) {
    rays.emplace_back(static_cast<float>((p.x - cx) / fx), static_cast<float>((p.y - cy) / fy),
                      1.0f);
  }
  const cv::Mat k(matrix());
  const cv::Vec3d no_rotation(0.0, 0.0, 0.0);
  const cv::Vec3d no_translation(0.0, 0.0, 0.0);
  std::vector<cv::Point2f> pixels;
  if (distortion == LensDistortion::kEquidistant) {
    cv::fisheye::projectPoints(rays, pixels, no_rotation, no_translation, k, coefficients);
  } else {
    cv::projectPoints(rays, no_rotation, no_translation, k, coefficients, pixels);
  }
  return pixels;
}

}  // namespace landmark_loop_closure
