#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

/// The database's 8-bit rows projected onto their own leading principal directions (uncentred:
/// inner products are what search compares), learned once from up to kSampleRows rows spread
/// evenly over the map's first rows, so that the inner product of two projections approximates that
/// of their rows. Exact search of a large map scans the projections (kDimension values a row
/// instead of the backbone's 4 320) and scores only the best of them exactly
/// (IndexOptions::coarse_from). Rows are projected in the order they are stored; append() takes one
/// row of QuantizedVectors' layout.
class RowProjection {
 public:
  static constexpr int kDimension = 256;
  static constexpr size_t kSampleRows = 512;

  /// Learns the directions from `vectors`' first `learn_from` rows (at least one; all of them when
  /// 0), so that a map opened again learns what it learned while it grew, and projects every row.
  explicit RowProjection(const QuantizedVectors& vectors, size_t learn_from = 0);

  /// A row projected: its values on the directions (QuantizedVectors' layout, dimension()
  /// values) and the length of what the directions leave of it.
  struct Projected {
    std::vector<uint8_t> row;
    float residual = 0.0f;
  };
  /// The projection of `row` (QuantizedVectors' layout, the learned rows' dimension).
  Projected project(const uint8_t* row) const;
  void append(const uint8_t* row);
  size_t size() const { return projected_.size(); }
  /// Directions kept: kDimension, or fewer when the sample spans fewer.
  int dimension() const { return static_cast<int>(directions_.rows()); }
  /// The product of a project()ed row's values with stored row `index`'s: their rows' product
  /// less that of what the directions leave of them.
  float dot(const Projected& query, size_t index) const {
    return projected_.dot(query.row.data(), index);
  }
  /// The directions describe a row whose residual is at most the 99th percentile of the
  /// learned-from rows'. A row beyond it (a place unlike the map's first rows, whose
  /// projection would rank it by what the directions miss) is scored exactly whatever its
  /// projection says.
  bool describes(float residual) const { return residual <= residual_limit_; }
  bool describes(size_t index) const { return describes(residuals_[index]); }
  /// Stored rows the directions do not describe.
  size_t undescribed() const { return undescribed_; }
  size_t bytes() const {
    return projected_.bytes() + residuals_.capacity() * sizeof(float) +
           static_cast<size_t>(directions_.size()) * sizeof(float);
  }

 private:
  int row_dimension_;
  /// One principal direction a row, unit length, the most variance first.
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> directions_;
  QuantizedVectors projected_;
  std::vector<float> residuals_;  ///< Of each stored row, in order.
  float residual_limit_ = 0.0f;
  size_t undescribed_ = 0;
};

}  // namespace landmark_loop_closure
