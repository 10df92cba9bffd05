#include "landmark_loop_closure/database/row_sketches.h"

#include <array>
#include <cstring>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

// SplitMix64: a fixed, well-mixed bucket and sign per position, the same on every machine.
uint64_t mixed(uint64_t value) {
  value += 0x9e3779b97f4a7c15ULL;
  value = (value ^ (value >> 30)) * 0xbf58476d1ce4e5b9ULL;
  value = (value ^ (value >> 27)) * 0x94d049bb133111ebULL;
  return value ^ (value >> 31);
}

}  // namespace

RowSketches::RowSketches(int row_dimension) : sketches_(kDimension) {
  if (row_dimension <= 0) throw std::invalid_argument("row dimension must be > 0");
  bucket_of_.resize(static_cast<size_t>(row_dimension));
  for (int i = 0; i < row_dimension; ++i) {
    const uint64_t hash = mixed(static_cast<uint64_t>(i));
    bucket_of_[static_cast<size_t>(i)] =
        static_cast<uint16_t>(((hash % kDimension) << 1) | ((hash >> 32) & 1));
  }
}

std::vector<uint8_t> RowSketches::sketch(const uint8_t* row) const {
  float scale = 0.0f;
  std::memcpy(&scale, row, sizeof(float));
  const auto* values = reinterpret_cast<const int8_t*>(row + sizeof(float));
  std::array<int32_t, kDimension> sums{};
  for (size_t i = 0; i < bucket_of_.size(); ++i) {
    const uint16_t bucket = bucket_of_[i];
    const int32_t value = values[i];
    sums[bucket >> 1] += (bucket & 1) ? -value : value;
  }
  std::array<float, kDimension> sketch{};
  for (int b = 0; b < kDimension; ++b) sketch[b] = scale * static_cast<float>(sums[b]);
  std::vector<uint8_t> encoded(sketches_.rowBytes());
  QuantizedVectors::encode(sketch.data(), kDimension, encoded.data());
  return encoded;
}

void RowSketches::append(const uint8_t* row) {
  const std::vector<uint8_t> encoded = sketch(row);
  sketches_.appendRow(encoded.data(), encoded.size());
}

}  // namespace landmark_loop_closure
