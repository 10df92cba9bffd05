#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace landmark_loop_closure {

/// Global descriptors as search keeps them in RAM and the map file keeps them on disk: each vector
/// as one float scale and one signed byte per value (4 + n bytes instead of 4n), compared by an
/// integer inner product. Rows are appended and never change. Storage grows in fixed chunks, so
/// appending never moves the rows already held (a vector's doubling would copy gigabytes at a
/// million keyframes and stall the worker).
class QuantizedVectors {
 public:
  explicit QuantizedVectors(int dimension);

  int dimension() const { return dimension_; }
  /// Bytes of one row: the scale, then `dimension` signed values.
  size_t rowBytes() const { return row_bytes_; }

  /// Writes the row of `vector` (`dimension` floats) into `row` (rowBytes() bytes). The scale is
  /// the largest magnitude over 127, so each value keeps 8 bits of its vector's own range;
  /// non-finite values count as 0.
  static void encode(const float* vector, int dimension, uint8_t* row);
  static std::vector<uint8_t> encode(const std::vector<float>& vector);
  /// The floats a row stands for.
  static std::vector<float> decode(const uint8_t* row, int dimension);
  /// Inner product of two rows of `dimension` values.
  static float dot(const uint8_t* a, const uint8_t* b, int dimension);

  /// Appends `vector` (`dimension` floats).
  void append(const float* vector);
  /// Appends a row as encode() wrote it. Throws std::invalid_argument for another length.
  void appendRow(const uint8_t* row, size_t bytes);
  /// Takes `count` rows (as encode() writes them, `stride` bytes apart: rowBytes() or more) into
  /// empty vectors without copying them: `owner` (a mapped file) keeps `rows` readable for as long
  /// as they are used. Rows appended later go after them, `stride` apart too. Throws
  /// std::logic_error when rows are held already, std::invalid_argument for a short stride.
  void adopt(std::shared_ptr<const void> owner, const uint8_t* rows, size_t count,
             size_t stride = 0);
  size_t size() const { return size_; }
  const uint8_t* row(size_t index) const {
    return chunks_[index / kChunkRows] + (index % kChunkRows) * row_stride_;
  }
  /// Inner product of a row built by encode() with row `index`.
  float dot(const uint8_t* query, size_t index) const { return dot(query, row(index), dimension_); }
  /// The first `rows` rows as vectors of their own, for another thread to read while these grow:
  /// adopted rows are shared (their owner kept alive), owned ones copied (at most kChunkRows when
  /// the rows were adopted).
  std::unique_ptr<QuantizedVectors> snapshot(size_t rows) const;
  /// Bytes held: the heap's and the adopted rows (memory once read, if the kernel's to reclaim).
  size_t bytes() const;

 private:
  static constexpr size_t kChunkRows = 1024;
  uint8_t* nextRow();

  int dimension_;
  size_t row_bytes_;
  size_t row_stride_;  ///< Bytes from one row to the next: rowBytes(), or an adopted file's.
  size_t size_ = 0;
  std::vector<const uint8_t*> chunks_;  ///< kChunkRows rows each: adopted ones, then owned_.
  std::vector<std::unique_ptr<uint8_t[]>> owned_;
  std::shared_ptr<const void> adopted_owner_;
  size_t adopted_rows_ = 0;
};

}  // namespace landmark_loop_closure
