#pragma once

// Field-level writing and reading of keyframe payloads (the map store's records, the old map
// file that lcd_db converts): little-endian integers and floats, counted lists and matrices,
// gathered into large writes and reads with one CRC-32C call per chunk. Private to the core
// library.

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {
namespace database_payload {

/// Why a file cannot be read or written; turned into the caller's error message at the top.
struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

template <typename Unsigned>
void encode(Unsigned value, uint8_t* out) {
  for (size_t i = 0; i < sizeof(Unsigned); ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
}

template <typename Unsigned>
Unsigned decode(const uint8_t* in) {
  Unsigned value = 0;
  for (size_t i = 0; i < sizeof(Unsigned); ++i) value |= static_cast<Unsigned>(in[i]) << (8 * i);
  return value;
}

/// Reads exactly `size` bytes at `offset` of `fd`; throws FormatError on a short read.
void readAt(int fd, uint64_t offset, void* out, size_t size);

class PayloadWriter {
 public:
  explicit PayloadWriter(std::FILE* file) : file_(file) {}

  void bytes(const void* data, size_t size);
  /// Checksums and writes what is buffered; call before the header is written.
  void flush();
  void u32(uint32_t value);
  void u64(uint64_t value);
  void i32(int value) { u32(static_cast<uint32_t>(value)); }
  void f64(double value);
  void count(size_t value);
  /// `n` floats in one write: the bulk of a keyframe (descriptors, keypoints, depths).
  void floats(const float* values, size_t n);
  void string(const std::string& text);
  void mat(const cv::Mat& matrix);

  uint32_t crc() const { return crc_; }
  /// Payload bytes written so far: the offset of the next field.
  uint64_t written() const { return written_; }

 private:
  std::FILE* file_;
  uint32_t crc_ = 0;
  uint64_t written_ = 0;
  std::vector<uint8_t> chunk_;  ///< Fields gathered into large writes and checksum calls.
};

/// Reads the payload bytes [begin, end) (offsets from the payload's start) of an open file,
/// in large chunks, checksumming every byte it reads. Each thread of a parallel load has its
/// own reader over its own range. Every length read is checked against the bytes left in the
/// range before anything is allocated.
class PayloadReader {
 public:
  PayloadReader(int fd, uint64_t payload_offset, uint64_t begin, uint64_t end);
  /// Reads `size` bytes held in memory (a record of the keyframe store).
  PayloadReader(const uint8_t* data, size_t size);

  void bytes(void* out, size_t size);
  uint32_t u32();
  uint64_t u64();
  int i32() { return static_cast<int>(u32()); }
  double f64();
  /// A list length whose items take at least `item_bytes` each: refused when they cannot fit in
  /// what is left, before anything is allocated.
  size_t count(size_t item_bytes);
  void floats(float* values, size_t n);
  std::string string();
  cv::Mat mat();

  /// CRC-32C of the range's bytes; complete once remaining() is 0.
  uint32_t crc() const { return crc_; }
  uint64_t remaining() const { return remaining_; }
  /// Payload offset of the next byte handed out.
  uint64_t position() const { return end_ - remaining_; }

 private:
  void refill();

  int fd_;
  const uint8_t* memory_ = nullptr;  ///< Set: reads come from here instead of fd_.
  uint64_t payload_offset_;          ///< File offset of the payload's first byte.
  uint64_t end_;
  uint64_t remaining_;  ///< Range bytes not yet handed out.
  uint64_t next_read_;  ///< Payload offset of the next byte to read from the file.
  std::vector<uint8_t> chunk_;
  size_t position_ = 0;
  uint32_t crc_ = 0;
};

}  // namespace database_payload
}  // namespace landmark_loop_closure
