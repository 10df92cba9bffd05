#pragma once

// Unit global descriptors drawn at random (places unrelated to each other), and a database of
// them, for the tests of the calibrated decision's background.
#include <cmath>
#include <cstdint>
#include <random>

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

}  // namespace test_support
}  // namespace landmark_loop_closure
