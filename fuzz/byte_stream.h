#pragma once

// The fuzz targets' input as a stream of bytes, numbers and quaternions; tests replay the kept
// inputs with the same reader.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <Eigen/Geometry>

namespace landmark_loop_closure {
namespace fuzz {

// Reads the input as a stream; past its end every read gives 0.
class ByteStream {
 public:
  ByteStream(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  bool empty() const { return offset_ >= size_; }
  uint8_t byte() { return offset_ < size_ ? data_[offset_++] : 0; }

  // Mostly small values (the size of real poses and covariances), sometimes one of the special
  // ones, sometimes any 8 bytes.
  double number() {
    const uint8_t kind = byte();
    if (kind < 8) {
      static const double kSpecial[] = {0.0,
                                        -0.0,
                                        std::numeric_limits<double>::quiet_NaN(),
                                        std::numeric_limits<double>::infinity(),
                                        -std::numeric_limits<double>::infinity(),
                                        std::numeric_limits<double>::denorm_min(),
                                        1e-300,
                                        1e300};
      return kSpecial[kind];
    }
    if (kind < 24) {
      double value = 0.0;
      uint8_t bytes[sizeof(double)];
      for (uint8_t& b : bytes) b = byte();
      std::memcpy(&value, bytes, sizeof(value));
      return value;
    }
    return static_cast<int8_t>(byte()) / 16.0;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t offset_ = 0;
};

inline Eigen::Quaterniond quaternion(ByteStream* in) {
  // As a message carries it: four numbers, not necessarily of unit length.
  const double x = in->number(), y = in->number(), z = in->number(), w = in->number();
  return Eigen::Quaterniond(w, x, y, z);
}

}  // namespace fuzz
}  // namespace landmark_loop_closure
