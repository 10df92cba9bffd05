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

// How the route's descriptors are spread.
enum class RouteShape {
  // Every dimension alike and no shared part: places far apart are orthogonal, the worst case
  // for a graph (no slope to follow until the search is near its target).
  kIsotropic,
  // Shaped like the shipped backbone's descriptors of real images (Gardens Point's 300, measured
  // by `lcd_bench_map --measure-route`): a part all places share (35 % of a descriptor's energy,
  // so unrelated places have cosine ~0.35) and the rest with variance falling as 1/k over its
  // principal directions (the real spectrum's slope, ~1.0 over its first 100). The first
  // kShapedDirections directions are random ones; the variance past them is spread over every
  // dimension, which makes the tail harder than the real one.
  kMeasured
};

// Successive global descriptors along a route: each random coordinate follows
// x <- 0.9 x + 0.45 n (steady variance 0.2025 / 0.19), so neighbours' varying parts have cosine
// ~0.9, falling to ~0.35 ten keyframes apart. A revisit adds noise for cosine ~0.9 to the place.
class Route {
 public:
  static constexpr double kSharedEnergy = 0.35;
  static constexpr int kShapedDirections = 256;

  Route(int dimension, unsigned seed, RouteShape shape = RouteShape::kIsotropic)
      : shape_(shape), state_(static_cast<size_t>(dimension)), random_(seed) {
    for (float& v : state_) v = normal_(random_);
    if (shape_ == RouteShape::kMeasured) shapeDirections(dimension);
  }
  std::vector<float> next() {
    step(&state_);
    if (shape_ == RouteShape::kIsotropic) {
      std::vector<float> unit = state_;
      normalise(&unit);
      return unit;
    }
    step(&latent_);
    std::vector<float> varying(state_.size());
    for (size_t i = 0; i < varying.size(); ++i) varying[i] = tail_scale_ * state_[i];
    for (size_t k = 0; k < latent_.size(); ++k) {
      const float weight = latent_scale_[k] * latent_[k];
      const float* direction = &directions_[k * state_.size()];
      for (size_t i = 0; i < varying.size(); ++i) varying[i] += weight * direction[i];
    }
    const float varying_scale =
        static_cast<float>(std::sqrt((1.0 - kSharedEnergy) * 0.19 / 0.2025));
    for (size_t i = 0; i < varying.size(); ++i) {
      varying[i] = shared_[i] + varying_scale * varying[i];
    }
    normalise(&varying);
    return varying;
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
  void step(std::vector<float>* values) {
    for (float& v : *values) v = 0.9f * v + 0.45f * normal_(random_);
  }
  // Unit-variance coordinates map to a varying part of unit expected energy: direction k gets
  // (1/k) / H(dimension) of it, the tail past kShapedDirections the rest, spread evenly.
  void shapeDirections(int dimension) {
    const size_t d = static_cast<size_t>(dimension);
    const int shaped = std::min(kShapedDirections, dimension);
    double harmonic = 0.0;
    for (int k = 1; k <= dimension; ++k) harmonic += 1.0 / k;
    double head = 0.0;
    latent_.resize(static_cast<size_t>(shaped));
    for (float& v : latent_) v = normal_(random_);
    directions_.resize(latent_.size() * d);
    for (int k = 1; k <= shaped; ++k) {
      const double share = (1.0 / k) / harmonic;
      head += share;
      latent_scale_.push_back(static_cast<float>(std::sqrt(share)));
      std::vector<float> direction(d);
      for (float& v : direction) v = normal_(random_);
      normalise(&direction);  // Random directions in thousands of dimensions: nearly orthogonal.
      std::copy(direction.begin(), direction.end(), &directions_[(k - 1) * d]);
    }
    tail_scale_ = static_cast<float>(std::sqrt(std::max(0.0, 1.0 - head) / dimension));
    shared_.resize(d);
    for (float& v : shared_) v = normal_(random_);
    normalise(&shared_);
    for (float& v : shared_) v *= static_cast<float>(std::sqrt(kSharedEnergy));
  }

  RouteShape shape_;
  std::vector<float> state_;  ///< One coordinate per dimension (the tail when kMeasured).
  std::vector<float> latent_;
  std::vector<float> latent_scale_;
  std::vector<float> directions_;  ///< kShapedDirections unit vectors, one after the other.
  std::vector<float> shared_;
  float tail_scale_ = 0.0f;
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
