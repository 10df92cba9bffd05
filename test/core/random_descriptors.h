#pragma once

// Unit global descriptors drawn at random (places unrelated to each other), and a database of
// them, for the tests of the calibrated decision's background; routes of related ones for the
// search's tests.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {
namespace test_support {

class RandomDescriptors {
 public:
  RandomDescriptors(int dimension, unsigned seed) : dimension_(dimension), random_(seed) {}

  ImageDescriptor next() {
    ImageDescriptor descriptor;
    descriptor.global.resize(static_cast<size_t>(dimension_));
    double norm = 0.0;
    for (float& x : descriptor.global) {
      x = normal_(random_);
      norm += x * x;
    }
    for (float& x : descriptor.global) x = static_cast<float>(x / std::sqrt(norm));
    return descriptor;
  }

  /// `keyframes` keyframes of descriptors of their own, ids and stamps 0, 1, ...
  void fill(KeyframeDatabase* database, uint64_t keyframes) {
    for (uint64_t id = 0; id < keyframes; ++id) {
      KeyframeRecord record;
      record.id = id;
      record.stamp = static_cast<double>(id);
      record.descriptor = next();
      database->add(record);
    }
  }

 private:
  int dimension_;
  std::mt19937 random_;
  std::normal_distribution<float> normal_;
};

/// A route through descriptor space: each keyframe a small random step from the last, as
/// neighbouring keyframes of a real sequence are.
inline std::vector<std::vector<float>> routeVectors(int keyframes, int dimension,
                                                    std::mt19937* random) {
  std::normal_distribution<float> normal;
  std::vector<float> current(static_cast<size_t>(dimension));
  for (float& v : current) v = normal(*random);
  std::vector<std::vector<float>> vectors;
  for (int i = 0; i < keyframes; ++i) {
    for (float& v : current) v = 0.9f * v + 0.45f * normal(*random);
    std::vector<float> unit = current;
    double norm = 0.0;
    for (float v : unit) norm += static_cast<double>(v) * v;
    for (float& v : unit) v = static_cast<float>(v / std::sqrt(norm));
    vectors.push_back(unit);
  }
  return vectors;
}

/// A database of `vectors` as keyframes, ids and stamps 0, 1, ...
inline KeyframeDatabase routeDatabase(const std::vector<std::vector<float>>& vectors,
                                      const IndexOptions& index) {
  KeyframeDatabase database(static_cast<int>(vectors.front().size()), index);
  for (size_t i = 0; i < vectors.size(); ++i) {
    KeyframeRecord keyframe;
    keyframe.id = i;
    keyframe.stamp = static_cast<double>(i);
    keyframe.descriptor.global = vectors[i];
    database.add(std::move(keyframe));
  }
  return database;
}

}  // namespace test_support
}  // namespace landmark_loop_closure
