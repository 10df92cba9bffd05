#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

/// Count sketches of the database's 8-bit rows: each value of a row adds, with a sign, into one of
/// kDimension sums chosen by its position (the same for every row), so the inner product of two
/// sketches estimates that of their rows without bias. Exact search of a large map scans the
/// sketches (17 times fewer bytes than the rows of the backbone's 4 320 values) and scores only
/// the best of them exactly (IndexOptions::coarse_from). Rows are sketched in the order they are
/// stored; append() takes one row of QuantizedVectors' layout.
class RowSketches {
 public:
  static constexpr int kDimension = 256;

  explicit RowSketches(int row_dimension);

  /// The sketch of `row` (QuantizedVectors' layout, row_dimension values), as a row of
  /// QuantizedVectors' layout with kDimension values.
  std::vector<uint8_t> sketch(const uint8_t* row) const;
  void append(const uint8_t* row);
  size_t size() const { return sketches_.size(); }
  /// Inner product of a sketch() with the sketch of stored row `index`.
  float dot(const uint8_t* query_sketch, size_t index) const {
    return sketches_.dot(query_sketch, index);
  }
  size_t bytes() const { return sketches_.bytes() + bucket_of_.capacity() * sizeof(uint16_t); }

 private:
  /// One entry per position of a row. Position i of a row adds into sum bucket_of_[i] >> 1, negated
  /// when its lowest bit is set.
  std::vector<uint16_t> bucket_of_;
  QuantizedVectors sketches_;
};

}  // namespace landmark_loop_closure
