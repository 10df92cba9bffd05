#include "landmark_loop_closure/database/row_projection.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace landmark_loop_closure {

namespace {

int dimensionOf(const QuantizedVectors& vectors) {
  return static_cast<int>(vectors.rowBytes() - sizeof(float));
}

// Row `index` of `vectors` as floats, into `target`.
template <typename Row>
void decodeInto(const QuantizedVectors& vectors, size_t index, Row&& target) {
  const int dimension = dimensionOf(vectors);
  const std::vector<float> values = QuantizedVectors::decode(vectors.row(index), dimension);
  target = Eigen::Map<const Eigen::RowVectorXf>(values.data(), dimension);
}

// The learned directions: the sample's Gram matrix (rows x rows, cheaper than the covariance of
// 4 320 values) gives them through its eigenvectors: v = X^T u / sqrt(lambda).
Eigen::MatrixXf principalDirections(const QuantizedVectors& vectors, size_t learn_from,
                                    int wanted) {
  const int dimension = dimensionOf(vectors);
  const size_t sample = std::min(learn_from, RowProjection::kSampleRows);
  Eigen::MatrixXf rows(static_cast<Eigen::Index>(sample), dimension);
  for (size_t k = 0; k < sample; ++k) {
    // Spread evenly over the map, the first and the last row included.
    const size_t index = sample == 1 ? 0 : k * (learn_from - 1) / (sample - 1);
    decodeInto(vectors, index, rows.row(static_cast<Eigen::Index>(k)));
  }
  const Eigen::MatrixXf gram = rows * rows.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXf> solver(gram);
  if (solver.info() != Eigen::Success) throw std::runtime_error("row projection: no eigenvectors");
  // Eigenvalues ascend: the last are the largest. Directions with no variance are left out.
  const Eigen::VectorXf& values = solver.eigenvalues();
  const float floor = std::max(values.maxCoeff(), 0.0f) * 1e-6f;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index k = values.size() - 1; k >= 0 && static_cast<int>(kept.size()) < wanted; --k) {
    if (values(k) > floor) kept.push_back(k);
  }
  Eigen::MatrixXf directions(static_cast<Eigen::Index>(std::max<size_t>(kept.size(), 1)),
                             dimension);
  directions.setZero();
  for (size_t d = 0; d < kept.size(); ++d) {
    const Eigen::VectorXf u = solver.eigenvectors().col(kept[d]);
    Eigen::RowVectorXf direction = u.transpose() * rows;
    const float norm = direction.norm();
    if (norm > 0.0f) direction /= norm;
    directions.row(static_cast<Eigen::Index>(d)) = direction;
  }
  return directions;
}

// The length of what the directions leave of a row: sqrt(|x|^2 - |Px|^2), the directions being
// orthonormal.
float residualNorm(const float* row, int dimension, const float* projected, int directions) {
  double whole = 0.0, kept = 0.0;
  for (int i = 0; i < dimension; ++i) whole += static_cast<double>(row[i]) * row[i];
  for (int i = 0; i < directions; ++i) kept += static_cast<double>(projected[i]) * projected[i];
  return static_cast<float>(std::sqrt(std::max(0.0, whole - kept)));
}

}  // namespace

RowProjection::RowProjection(const QuantizedVectors& vectors, size_t learn_from)
    : row_dimension_(dimensionOf(vectors)), projected_(1) {
  if (vectors.size() == 0) throw std::invalid_argument("row projection: no rows to learn from");
  learn_from = learn_from == 0 ? vectors.size() : std::min(learn_from, vectors.size());
  directions_ = principalDirections(vectors, learn_from, kDimension);
  projected_ = QuantizedVectors(static_cast<int>(directions_.rows()));
  // The stored rows a block at a time: one matrix product instead of a product per row.
  constexpr size_t kBlock = 512;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> projected;
  std::vector<uint8_t> encoded(projected_.rowBytes());
  for (size_t first = 0; first < vectors.size(); first += kBlock) {
    const size_t count = std::min(kBlock, vectors.size() - first);
    block.resize(static_cast<Eigen::Index>(count), row_dimension_);
    for (size_t k = 0; k < count; ++k) {
      decodeInto(vectors, first + k, block.row(static_cast<Eigen::Index>(k)));
    }
    projected.noalias() = block * directions_.transpose();
    for (size_t k = 0; k < count; ++k) {
      const auto index = static_cast<Eigen::Index>(k);
      QuantizedVectors::encode(projected.row(index).data(), static_cast<int>(projected.cols()),
                               encoded.data());
      projected_.appendRow(encoded.data(), encoded.size());
      residuals_.push_back(residualNorm(block.row(index).data(), row_dimension_,
                                        projected.row(index).data(),
                                        static_cast<int>(projected.cols())));
    }
  }
  std::vector<float> learned(residuals_.begin(),
                             residuals_.begin() + static_cast<std::ptrdiff_t>(learn_from));
  const auto percentile =
      learned.begin() + static_cast<std::ptrdiff_t>((learned.size() - 1) * 99 / 100);
  std::nth_element(learned.begin(), percentile, learned.end());
  residual_limit_ = *percentile;
  for (const float residual : residuals_) undescribed_ += !describes(residual);
}

RowProjection::Projected RowProjection::project(const uint8_t* row) const {
  const std::vector<float> values = QuantizedVectors::decode(row, row_dimension_);
  const Eigen::VectorXf projected =
      directions_ * Eigen::Map<const Eigen::VectorXf>(values.data(), row_dimension_);
  Projected result;
  result.row.resize(projected_.rowBytes());
  QuantizedVectors::encode(projected.data(), static_cast<int>(projected.size()), result.row.data());
  result.residual = residualNorm(values.data(), row_dimension_, projected.data(),
                                 static_cast<int>(projected.size()));
  return result;
}

void RowProjection::append(const uint8_t* row) {
  const Projected projected = project(row);
  projected_.appendRow(projected.row.data(), projected.row.size());
  residuals_.push_back(projected.residual);
  undescribed_ += !describes(projected.residual);
}

}  // namespace landmark_loop_closure
