#pragma once

// What the scaling benchmarks (lcd_bench_scaling, lcd_bench_map) store: one described keyframe
// as the node keeps it, and synthetic global descriptors along a route.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/sim/corridor_world.h"

namespace landmark_loop_closure {
namespace bench {

inline void normalise(std::vector<float>* values) {
  double norm = 0.0;
  for (const float v : *values) norm += static_cast<double>(v) * v;
  const double scale = norm > 0.0 ? 1.0 / std::sqrt(norm) : 0.0;
  for (float& v : *values) v = static_cast<float>(v * scale);
}

// Successive global descriptors along a route: x <- 0.9 x + 0.45 n keeps each dimension's
// variance steady and the cosine of neighbours near 0.9, falling to ~0.35 ten keyframes apart.
class Route {
 public:
  Route(int dimension, unsigned seed) : state_(static_cast<size_t>(dimension)), random_(seed) {
    for (float& v : state_) v = normal_(random_);
  }
  std::vector<float> next() {
    for (float& v : state_) v = 0.9f * v + 0.45f * normal_(random_);
    std::vector<float> unit = state_;
    normalise(&unit);
    return unit;
  }
  // `place` seen again: cosine ~0.9 to it.
  std::vector<float> revisit(const std::vector<float>& place) {
    const float sigma = std::sqrt(0.2346f / static_cast<float>(place.size()));
    std::vector<float> seen = place;
    for (float& v : seen) v += sigma * normal_(random_);
    normalise(&seen);
    return seen;
  }
  std::mt19937& random() { return random_; }

 private:
  std::vector<float> state_;
  std::mt19937 random_;
  std::normal_distribution<float> normal_;
};

/// A generated corridor view (grey).
inline cv::Mat corridorView() {
  const sim::CorridorWorld world;
  return world.render(world.poseAt(5.0, 0.0), sim::CameraModel{}, sim::Lighting{}, 1);
}

/// `image` as the node stores a keyframe of it with a depth camera: its descriptor, ORB keypoints
/// found at most 640 pixels wide (as verification sees it), each with a 3D point on its ray and a
/// depth deviation, and the 160x120 thumbnail.
inline KeyframeRecord describedKeyframe(const DescriptorExtractor& extractor,
                                        const cv::Mat& image) {
  cv::Mat working;
  const double shrink = std::min(1.0, 640.0 / image.cols);
  cv::resize(image, working, cv::Size(), shrink, shrink, cv::INTER_AREA);
  KeyframeRecord keyframe;
  keyframe.descriptor = extractor.describe(image);
  keyframe.local_features = GeometricVerifier(VerificationOptions{}).extract(working);
  // Every keypoint with a depth (the most a depth camera gives), on its ray through a pinhole
  // camera of about 60 degrees across.
  LocalFeatures& local = keyframe.local_features;
  const float focal = 0.9f * static_cast<float>(working.cols);
  const cv::Point2f centre(0.5f * static_cast<float>(working.cols),
                           0.5f * static_cast<float>(working.rows));
  for (size_t i = 0; i < local.points.size(); ++i) {
    const float z = 1.0f + static_cast<float>((i * 37) % 100) * 0.1f;
    const cv::Point2f ray = (local.points[i] - centre) / focal;
    local.points3d.emplace_back(z * ray.x, z * ray.y, z);
    local.depth_sd.push_back(0.003f * z * z);
  }
  cv::Mat thumbnail;
  cv::resize(image, thumbnail, cv::Size(160, 120));
  keyframe.thumbnail = encodeThumbnail(thumbnail);
  return keyframe;
}

}  // namespace bench
}  // namespace landmark_loop_closure
