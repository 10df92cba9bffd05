#pragma once

// What search needs of a map's keyframes, saved beside it as one flat file, PATH-vectors: a
// 16-byte header ("LLCVEC2\n", u32 dimension, u32 summary bytes), the 8-bit rows
// (QuantizedVectors, id order), then each row's summary (id, session, stamp, pose and path).
// Opening a map maps the file and uses the rows in place instead of reading every keyframe's
// database row (7 s at 1 000 000 keyframes against ~1 s). Written at a clean shutdown with the
// graph: the rows are appended to the ones saved before, the summaries written again after them.
// Its row count and CRC-32Cs are kept in the map, so a file from another map, a damaged one or
// one a crash left half-updated is never used. Private to the core library.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {
namespace vector_file {

/// Bytes of one keyframe's summary in the file: id, session, stamp, then the pose and path as
/// the map's `motion` column holds them.
constexpr size_t kSummaryBytes = 8 + 4 + 8 + 72;

/// What the map keeps about its saved rows file.
struct Seal {
  uint64_t rows = 0;
  uint32_t rows_checksum = 0;       ///< CRC-32C of the header and the rows.
  uint32_t summaries_checksum = 0;  ///< CRC-32C of the summaries.
};

/// Writes the first `rows` rows of `vectors` and their summaries (`summary_of(row)`) to `path`.
/// When `earlier` seals the file at `path` as holding the first earlier.rows of these rows, only
/// the rows after them are appended (the summaries are written again whole); otherwise the file
/// is written anew through `path`.tmp. Throws std::runtime_error naming the file (disk full).
Seal write(const std::string& path, const QuantizedVectors& vectors, size_t rows,
           const std::function<const KeyframeSummary&(size_t)>& summary_of,
           const Seal* earlier = nullptr);

/// A file written by write(), mapped read-only and checked against its seal.
class Mapped {
 public:
  /// nullptr when `path` is missing, not a regular file, or not what `seal` and `dimension` say
  /// (another map's, damaged, half-updated).
  static std::shared_ptr<const Mapped> open(const std::string& path, const Seal& seal,
                                            int dimension);
  ~Mapped();
  Mapped(const Mapped&) = delete;
  Mapped& operator=(const Mapped&) = delete;

  uint64_t rows() const { return rows_; }
  /// The rows, one after the other (rows() x (4 + dimension) bytes).
  const uint8_t* firstRow() const { return base_ + header_bytes_; }
  /// Row `index`'s summary. Throws database_payload::FormatError for a damaged one.
  KeyframeSummary summary(size_t index) const;

 private:
  Mapped() = default;
  const uint8_t* base_ = nullptr;
  size_t length_ = 0;
  size_t header_bytes_ = 0;
  size_t row_bytes_ = 0;
  uint64_t rows_ = 0;
};

}  // namespace vector_file
}  // namespace landmark_loop_closure
