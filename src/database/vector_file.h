#pragma once

// The search rows of a map (QuantizedVectors, id order) as one flat file beside it, PATH-vectors:
// "LLCVEC1\n", u32 dimension, u64 rows, then the rows. Opening a map reads them in one sequential
// pass instead of from every keyframe's database row (a tenth of the time at 1 000 000
// keyframes). Written at a clean shutdown with the graph; its CRC-32C is kept in the map, so a
// file from another map or a damaged one is never used. Private to the core library.

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {
namespace vector_file {

/// Writes the first `rows` rows of `vectors` to `path` through `path`.tmp, renamed at the end.
/// Returns the file's CRC-32C. Throws std::runtime_error naming the file (disk full).
uint32_t write(const std::string& path, const QuantizedVectors& vectors, size_t rows);

/// Rows of a file written by write(), read in order.
class Reader {
 public:
  /// Opens `path` when its CRC-32C is `checksum` and it holds rows of `dimension` values; else
  /// valid() is false (missing, damaged, another map's).
  Reader(const std::string& path, uint32_t checksum, int dimension);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  bool valid() const { return file_ != nullptr; }
  uint64_t rows() const { return rows_; }
  /// The next row (rowBytes() bytes), valid until the next call; nullptr past the last or on a
  /// read error.
  const uint8_t* next();

 private:
  std::FILE* file_ = nullptr;
  uint64_t rows_ = 0;
  uint64_t read_ = 0;
  size_t row_bytes_ = 0;
  std::vector<uint8_t> chunk_;  ///< Rows read ahead in one call.
  size_t chunk_rows_ = 0;
  size_t chunk_next_ = 0;
};

}  // namespace vector_file
}  // namespace landmark_loop_closure
