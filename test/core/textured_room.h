// A box-shaped room with richly textured walls, floor and ceiling, rendered by ray casting with
// bilinear texture sampling: image pairs with known relative poses and keypoints spread over
// the whole image at many depths, for geometric tests.
#pragma once

#include <array>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {
namespace test {

class TexturedRoom {
 public:
  /// Room [-half_x, half_x] x [-half_y, half_y] x [0, height] (metres), z up.
  explicit TexturedRoom(uint64_t seed = 11) {
    cv::RNG rng(seed);
    for (cv::Mat& texture : textures_) {
      texture = cv::Mat(kTexturePixels, kTexturePixels, CV_8UC1, cv::Scalar(128));
      for (int i = 0; i < 900; ++i) {
        const cv::Point centre(rng.uniform(0, kTexturePixels), rng.uniform(0, kTexturePixels));
        const int size = rng.uniform(6, 40);
        const cv::Scalar grey(rng.uniform(0, 256));
        if (i % 2 == 0) {
          cv::rectangle(texture, centre, centre + cv::Point(size, rng.uniform(6, 40)), grey,
                        cv::FILLED);
        } else {
          cv::circle(texture, centre, size / 2, grey, cv::FILLED);
        }
      }
    }
  }

  /// Grey image seen by a pinhole camera (focal f, principal point at the centre) whose optical
  /// axes (x right, y down, z forward) are `world_from_camera`. Each pixel averages
  /// kSamplesPerAxis^2 rays over its area, as a sensor integrates light: one ray per pixel aliases
  /// the texture, and the aliasing moves keypoints with the viewpoint, which no camera does.
  cv::Mat render(const Eigen::Isometry3d& world_from_camera, double focal, cv::Size size) const {
    cv::Mat image(size, CV_8UC1);
    const Eigen::Vector3d origin = world_from_camera.translation();
    const double cx = 0.5 * (size.width - 1);
    const double cy = 0.5 * (size.height - 1);
    for (int row = 0; row < size.height; ++row) {
      for (int col = 0; col < size.width; ++col) {
        double sum = 0.0;
        for (int sy = 0; sy < kSamplesPerAxis; ++sy) {
          for (int sx = 0; sx < kSamplesPerAxis; ++sx) {
            const double x = col - 0.5 + (sx + 0.5) / kSamplesPerAxis;
            const double y = row - 0.5 + (sy + 0.5) / kSamplesPerAxis;
            const Eigen::Vector3d ray = world_from_camera.linear() *
                                        Eigen::Vector3d((x - cx) / focal, (y - cy) / focal, 1.0);
            sum += shade(origin, ray);
          }
        }
        image.at<uchar>(row, col) =
            cv::saturate_cast<uchar>(sum / (kSamplesPerAxis * kSamplesPerAxis));
      }
    }
    return image;
  }

  /// Depth (metres along the optical axis) at each pixel centre, as a registered depth camera
  /// gives it: CV_32FC1.
  cv::Mat renderDepth(const Eigen::Isometry3d& world_from_camera, double focal,
                      cv::Size size) const {
    cv::Mat depth(size, CV_32FC1);
    const double cx = 0.5 * (size.width - 1);
    const double cy = 0.5 * (size.height - 1);
    for (int row = 0; row < size.height; ++row) {
      for (int col = 0; col < size.width; ++col) {
        const Eigen::Vector3d ray = world_from_camera.linear() *
                                    Eigen::Vector3d((col - cx) / focal, (row - cy) / focal, 1.0);
        int face = -1;
        // The ray's optical z component is 1, so its multiple is the depth.
        const double z = nearestHit(world_from_camera.translation(), ray, &face);
        depth.at<float>(row, col) = face < 0 ? 0.0f : static_cast<float>(z);
      }
    }
    return depth;
  }

  static constexpr double kHalfX = 4.0;
  static constexpr double kHalfY = 3.0;
  static constexpr double kHeight = 3.0;

 private:
  static constexpr int kSamplesPerAxis = 3;
  static constexpr int kTexturePixels = 1000;
  static constexpr double kPixelsPerMetre = 120.0;

  // The multiple of `ray` at which it leaves the room, and through which face (-1: none).
  static double nearestHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray, int* face) {
    const std::array<double, 3> low = {-kHalfX, -kHalfY, 0.0};
    const std::array<double, 3> high = {kHalfX, kHalfY, kHeight};
    double nearest = 1e9;
    *face = -1;
    for (int axis = 0; axis < 3; ++axis) {
      if (std::abs(ray(axis)) < 1e-12) continue;
      const double bound = ray(axis) > 0.0 ? high[axis] : low[axis];
      const double distance = (bound - origin(axis)) / ray(axis);
      if (distance > 0.0 && distance < nearest) {
        nearest = distance;
        *face = 2 * axis + (ray(axis) > 0.0 ? 1 : 0);
      }
    }
    return nearest;
  }

  // The nearest wall the ray hits, sampled bilinearly in that wall's texture.
  double shade(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray) const {
    int face = -1;
    const double nearest = nearestHit(origin, ray, &face);
    if (face < 0) return 0.0;
    const Eigen::Vector3d hit = origin + nearest * ray;
    const int axis = face / 2;
    const double u = hit((axis + 1) % 3) + 5.0;  // Offsets keep coordinates positive.
    const double v = hit((axis + 2) % 3) + 5.0;
    return sample(textures_[static_cast<size_t>(face)], u * kPixelsPerMetre, v * kPixelsPerMetre);
  }

  static double sample(const cv::Mat& texture, double x, double y) {
    const int x0 = static_cast<int>(std::floor(x));
    const int y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0;
    const double fy = y - y0;
    auto at = [&](int xi, int yi) {
      return static_cast<double>(
          texture.at<uchar>(((yi % kTexturePixels) + kTexturePixels) % kTexturePixels,
                            ((xi % kTexturePixels) + kTexturePixels) % kTexturePixels));
    };
    const double value = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
    return value;
  }

  std::array<cv::Mat, 6> textures_;
};

/// Camera at (x, y, z) in the room, looking along the horizontal heading `yaw` (radians from +x,
/// counter-clockwise), tilted down by `pitch`.
inline Eigen::Isometry3d cameraPose(double x, double y, double z, double yaw, double pitch = 0.0) {
  Eigen::Matrix3d body_from_optical;  // Optical z forward = body x; optical x right = -body y.
  body_from_optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                      .toRotationMatrix() *
                  body_from_optical;
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

}  // namespace test
}  // namespace landmark_loop_closure
