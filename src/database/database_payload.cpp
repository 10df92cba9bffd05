#include "database/database_payload.h"

#include "common/crc32c.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace landmark_loop_closure {
namespace database_payload {

namespace {

constexpr size_t kChunkBytes = 4 << 20;

// Bytes of a matrix element in the file: elements are stored as the host's, swapped to little
// endian on big-endian hosts.
void swapElements(uint8_t* data, size_t bytes, size_t element) {
  if (element <= 1) return;
  for (size_t start = 0; start + element <= bytes; start += element) {
    for (size_t i = 0; i < element / 2; ++i)
      std::swap(data[start + i], data[start + element - 1 - i]);
  }
}

bool hostIsLittleEndian() {
  const uint16_t probe = 1;
  uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

bool supportedMatType(int type) {
  return type == CV_8UC1 || type == CV_16UC1 || type == CV_16FC1 || type == CV_32FC1;
}

}  // namespace

void readAt(int fd, uint64_t offset, void* out, size_t size) {
  auto* target = static_cast<uint8_t*>(out);
  while (size > 0) {
    const ssize_t got = ::pread(fd, target, size, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw FormatError(std::strerror(errno));
    if (got == 0) throw FormatError("truncated: the file ends inside its payload");
    target += got;
    offset += static_cast<uint64_t>(got);
    size -= static_cast<size_t>(got);
  }
}

void PayloadWriter::bytes(const void* data, size_t size) {
  if (size == 0) return;
  const auto* begin = static_cast<const uint8_t*>(data);
  chunk_.insert(chunk_.end(), begin, begin + size);
  written_ += size;
  if (chunk_.size() >= kChunkBytes) flush();
}

void PayloadWriter::flush() {
  if (chunk_.empty()) return;
  crc_ = crc32c(crc_, chunk_.data(), chunk_.size());
  if (std::fwrite(chunk_.data(), 1, chunk_.size(), file_) != chunk_.size()) {
    throw FormatError(std::strerror(errno));
  }
  chunk_.clear();
}

void PayloadWriter::u32(uint32_t value) {
  uint8_t buffer[4];
  encode(value, buffer);
  bytes(buffer, 4);
}

void PayloadWriter::u64(uint64_t value) {
  uint8_t buffer[8];
  encode(value, buffer);
  bytes(buffer, 8);
}

void PayloadWriter::f64(double value) {
  uint64_t bits = 0;
  std::memcpy(&bits, &value, 8);
  u64(bits);
}

void PayloadWriter::count(size_t value) {
  if (value > UINT32_MAX) throw FormatError("more than 2^32 items in one list");
  u32(static_cast<uint32_t>(value));
}

void PayloadWriter::floats(const float* values, size_t n) {
  if (n == 0) return;
  if (hostIsLittleEndian()) {
    bytes(values, n * 4);
    return;
  }
  std::vector<uint8_t> buffer(n * 4);
  std::memcpy(buffer.data(), values, n * 4);
  swapElements(buffer.data(), buffer.size(), 4);
  bytes(buffer.data(), buffer.size());
}

void PayloadWriter::string(const std::string& text) {
  count(text.size());
  bytes(text.data(), text.size());
}

void PayloadWriter::mat(const cv::Mat& matrix) {
  if (!matrix.empty() && !supportedMatType(matrix.type())) {
    throw FormatError("cannot store a matrix of type " + std::to_string(matrix.type()));
  }
  i32(matrix.rows);
  i32(matrix.cols);
  i32(matrix.empty() ? CV_8UC1 : matrix.type());
  const size_t row_bytes = static_cast<size_t>(matrix.cols) * matrix.elemSize();
  std::vector<uint8_t> row(row_bytes);
  for (int r = 0; r < matrix.rows; ++r) {
    std::memcpy(row.data(), matrix.ptr(r), row_bytes);
    if (!hostIsLittleEndian()) swapElements(row.data(), row_bytes, matrix.elemSize1());
    bytes(row.data(), row_bytes);
  }
}

PayloadReader::PayloadReader(int fd, uint64_t payload_offset, uint64_t begin, uint64_t end)
    : fd_(fd),
      payload_offset_(payload_offset),
      end_(end),
      remaining_(end >= begin ? end - begin : 0),
      next_read_(begin) {}

PayloadReader::PayloadReader(const uint8_t* data, size_t size)
    : fd_(-1), memory_(data), payload_offset_(0), end_(size), remaining_(size), next_read_(0) {}

void PayloadReader::bytes(void* out, size_t size) {
  if (size > remaining_) throw FormatError("an entry runs past the end of its part of the file");
  remaining_ -= size;
  auto* target = static_cast<uint8_t*>(out);
  while (size > 0) {
    if (position_ == chunk_.size()) refill();
    const size_t take = std::min(size, chunk_.size() - position_);
    std::memcpy(target, chunk_.data() + position_, take);
    position_ += take;
    target += take;
    size -= take;
  }
}

uint32_t PayloadReader::u32() {
  uint8_t buffer[4];
  bytes(buffer, 4);
  return decode<uint32_t>(buffer);
}

uint64_t PayloadReader::u64() {
  uint8_t buffer[8];
  bytes(buffer, 8);
  return decode<uint64_t>(buffer);
}

double PayloadReader::f64() {
  const uint64_t bits = u64();
  double value = 0.0;
  std::memcpy(&value, &bits, 8);
  return value;
}

size_t PayloadReader::count(size_t item_bytes) {
  const uint64_t n = u32();
  if (n * item_bytes > remaining_) throw FormatError("a list is longer than the file");
  return static_cast<size_t>(n);
}

void PayloadReader::floats(float* values, size_t n) {
  if (n == 0) return;
  bytes(values, n * 4);
  if (!hostIsLittleEndian()) swapElements(reinterpret_cast<uint8_t*>(values), n * 4, 4);
}

std::string PayloadReader::string() {
  std::string text(count(1), '\0');
  bytes(text.data(), text.size());
  return text;
}

cv::Mat PayloadReader::mat() {
  const int rows = i32();
  const int cols = i32();
  const int type = i32();
  if (rows < 0 || cols < 0 || !supportedMatType(type)) {
    throw FormatError("a matrix has a bad shape or type");
  }
  const uint64_t total = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) *
                         static_cast<uint64_t>(CV_ELEM_SIZE(type));
  if (total > remaining_) throw FormatError("a matrix is larger than the file");
  if (rows == 0 || cols == 0) return {};
  cv::Mat matrix(rows, cols, type);
  // Freshly allocated and continuous: one read fills it.
  bytes(matrix.data, static_cast<size_t>(total));
  if (!hostIsLittleEndian())
    swapElements(matrix.data, static_cast<size_t>(total), matrix.elemSize1());
  return matrix;
}

// Reads the next chunk and checksums it whole (one call per megabytes, not per field: loading
// is bound by memory speed, not by call overhead).
void PayloadReader::refill() {
  const size_t size = static_cast<size_t>(std::min<uint64_t>(end_ - next_read_, kChunkBytes));
  if (size == 0) throw FormatError("truncated: the file ends inside its payload");
  chunk_.resize(size);
  if (memory_ != nullptr) {
    std::memcpy(chunk_.data(), memory_ + next_read_, size);
  } else {
    readAt(fd_, payload_offset_ + next_read_, chunk_.data(), size);
  }
  crc_ = crc32c(crc_, chunk_.data(), size);
  next_read_ += size;
  position_ = 0;
}

}  // namespace database_payload
}  // namespace landmark_loop_closure
