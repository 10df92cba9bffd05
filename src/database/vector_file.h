#pragma once

// The map's search rows, PATH-vectors beside the map: a 16-byte header ("LLCVEC3\n", u32
// dimension, u32 summary bytes), then one entry per keyframe in id order: its 8-bit global row
// (QuantizedVectors) and its summary (id, session, stamp, pose and path). The only copy of the
// rows: each entry is written before its keyframe's transaction commits, so every committed
// keyframe has one (a killed process keeps what it wrote; an entry past the map's keyframes is
// one whose commit never came, and is written over). Opening a map maps the file and search uses
// the rows in place, as the kernel reads them (1 000 000 keyframes: 4.4 GB). The map keeps each
// entry's CRC-32C and, at a clean shutdown, the CRC-32C of all entries so far (the seal): the
// entries after it are checked at open, the sealed part in one pass by a check that may run
// beside search (KeyframeStore::startIntegrityCheck). Private to the core library.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {
namespace vector_file {

/// Bytes of one keyframe's summary in an entry: id, session, stamp, then the pose and path as
/// the map's `motion` column holds them.
constexpr size_t kSummaryBytes = 8 + 4 + 8 + 72;
constexpr size_t kHeaderBytes = 16;

/// A summary as entries (and the summaries file saved at a clean shutdown) hold it:
/// kSummaryBytes at `out`.
void encodeSummary(const KeyframeSummary& summary, uint8_t* out);
/// Throws database_payload::FormatError for a damaged one.
KeyframeSummary decodeSummary(const uint8_t* at);

/// Bytes of one entry: the row (scale and `dimension` values), then the summary.
size_t entryBytes(int dimension);
/// One entry: `row` (QuantizedVectors::encode) followed by `summary`.
std::vector<uint8_t> entry(const std::vector<uint8_t>& row, const KeyframeSummary& summary);

/// The file open for writing entries, held by the map's store.
class Writer {
 public:
  /// Opens `path`, creating it with its header when missing. Throws std::runtime_error naming
  /// the file when it cannot be opened or created, is not a regular file or has another header.
  Writer(const std::string& path, int dimension);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Writes `entry` as entry number `position`. Throws std::runtime_error (disk full).
  void write(size_t position, const uint8_t* entry);
  /// Entry `position` as the file holds it; empty when the file is shorter.
  std::vector<uint8_t> read(size_t position) const;
  /// Entries the file has room for (whole ones).
  uint64_t entriesOnDisk() const;
  /// Flushes what was written to the disk. Throws std::runtime_error.
  void sync();
  /// Cuts the file after `entries` entries. Throws std::runtime_error.
  void truncate(uint64_t entries);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  size_t entry_bytes_;
};

/// The first entries of a file, mapped read-only (a file grown later keeps this view).
class Mapped {
 public:
  /// The first `entries` entries of `path`; nullptr when it is missing, not a regular file,
  /// shorter, or has another header.
  static std::shared_ptr<const Mapped> open(const std::string& path, int dimension,
                                            uint64_t entries);
  ~Mapped();
  Mapped(const Mapped&) = delete;
  Mapped& operator=(const Mapped&) = delete;

  uint64_t entries() const { return entries_; }
  size_t entryBytes() const { return entry_bytes_; }
  const uint8_t* entry(size_t index) const { return base_ + kHeaderBytes + index * entry_bytes_; }
  /// Entry `index`'s row; rows follow each other entryBytes() apart.
  const uint8_t* row(size_t index) const { return entry(index); }
  /// Entry `index`'s summary. Throws database_payload::FormatError for a damaged one.
  KeyframeSummary summary(size_t index) const;
  /// CRC-32C of the header and entries [0, `count`), read front to back.
  uint32_t checksum(uint64_t count) const;
  /// The same, given up (nullopt) soon after `stop` becomes true.
  std::optional<uint32_t> checksum(uint64_t count, const std::atomic<bool>& stop) const;
  /// Tells the kernel search reads rows here and there from now on.
  void readAtRandom() const;

 private:
  Mapped() = default;
  std::optional<uint32_t> checksumUnless(uint64_t count, const std::atomic<bool>* stop) const;
  const uint8_t* base_ = nullptr;
  size_t length_ = 0;
  size_t entry_bytes_ = 0;
  size_t row_bytes_ = 0;
  uint64_t entries_ = 0;
};

}  // namespace vector_file
}  // namespace landmark_loop_closure
