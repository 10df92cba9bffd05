#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "landmark_loop_closure/geometry/geometric_verification.h"

namespace landmark_loop_closure {
namespace sim {

/// A planar pose: x, y in metres, yaw in radians (x forward, y left, z up).
struct Pose2D {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

struct CameraModel {
  int width = 320;
  int height = 240;
  double focal_px = 200.0;  ///< Same in x and y; principal point at the image centre.
  double height_m = 1.2;    ///< Camera height above the floor.
  /// Where the camera sits on the robot (the pose the sequence gives is the robot's base): this
  /// far ahead of it, and pitched down by this angle (the mount x and pitch of camera_mount).
  double forward_m = 0.0;
  double pitch_rad = 0.0;

  /// Pinhole intrinsics of the rendered images (pixel centres at integer coordinates).
  CameraIntrinsics intrinsics() const {
    CameraIntrinsics k;
    k.fx = k.fy = focal_px;
    k.cx = (width - 1) / 2.0;
    k.cy = (height - 1) / 2.0;
    k.image_size = cv::Size(width, height);
    return k;
  }
};

struct Lighting {
  double gain = 1.0;
  double offset = 0.0;
  double noise_sigma = 2.0;  ///< Grey levels of Gaussian noise.
};

/// A closed corridor (a rounded rectangle) with procedurally textured walls, rendered by ray
/// casting. Textures depend only on the seed, so a place looks the same on every lap up to the
/// viewpoint and lighting, and different places look different (with a few repeated posters, so
/// that false loops are possible).
class CorridorWorld {
 public:
  struct Options {
    double length = 24.0;  ///< Centre line: outer extent in x (metres).
    double width = 14.0;   ///< Centre line: outer extent in y.
    double corner_radius = 3.0;
    double corridor_width = 3.0;
    double wall_height = 2.6;
    double pixels_per_metre = 80.0;
    uint32_t seed = 7;
    /// > 0: the walls are bays of this many metres that look alike (the same door, lockers and
    /// notice board in each, told apart only by a small room-number plate), as in an office or
    /// school corridor: the case where a threshold that suits a varied route publishes false
    /// loops.
    double bay_length = 0.0;
  };

  explicit CorridorWorld(const Options& options);
  CorridorWorld() : CorridorWorld(Options{}) {}

  /// Length of one lap along the centre line.
  double lapLength() const { return centre_length_; }
  /// Pose at arc length s (wrapped to one lap), moved `lateral` metres to the left of the centre
  /// line, facing along it.
  Pose2D poseAt(double s, double lateral) const;

  /// Renders an 8-bit grey image from a camera at `pose` looking along its x axis.
  cv::Mat render(const Pose2D& pose, const CameraModel& camera, const Lighting& lighting,
                 uint32_t noise_seed) const;
  /// The depth image (32-bit float, metres along the optical axis) registered to render()'s
  /// image; 0 where nothing is hit (the ceiling).
  cv::Mat renderDepth(const Pose2D& pose, const CameraModel& camera) const;

 private:
  struct Segment {
    Eigen::Vector2d a, b;
    int wall = 0;          ///< Index into wall_textures_.
    double u_start = 0.0;  ///< Texture coordinate (metres along the wall) at a.
  };

  struct Hit {
    const Segment* segment = nullptr;  ///< Null: the ray hits no wall.
    double distance = 0.0;             ///< Along the ray, metres.
    double u = 0.0;                    ///< Texture coordinate on the wall.
  };
  Hit castRay(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction) const;
  /// The nearest hit among `segments` only.
  static Hit castRayAmong(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction,
                          const std::vector<const Segment*>& segments);
  /// A camera ahead of the base or pitched: one ray per pixel (render() and renderDepth() cast
  /// one per column for a level camera at the base). `depth` set: optical depths, else grey.
  cv::Mat renderMounted(const Pose2D& pose, const CameraModel& camera, bool depth) const;
  Eigen::Vector2d centreAt(double s, Eigen::Vector2d* tangent) const;
  void buildWall(int wall, double offset);
  /// Walls of options_.bay_length bays: one bay drawn, repeated, each with its own plate.
  cv::Mat bayTexture(int wall, int cols, int rows) const;

  Options options_;
  double centre_length_ = 0.0;
  std::vector<Segment> segments_;
  std::vector<cv::Mat> wall_textures_;
};

}  // namespace sim
}  // namespace landmark_loop_closure
