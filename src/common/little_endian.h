#pragma once

// Byte-exact little-endian encoding for the package's small binary files (whitening, broad
// autoencoder models), independent of the host's byte order.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace landmark_loop_closure {

/// Written after each file's magic; a reader that sees other bytes knows the file is damaged.
constexpr uint32_t kByteOrderMark = 0x01020304u;

class LittleEndianWriter {
 public:
  void bytes(const void* data, size_t size) {
    const auto* begin = static_cast<const uint8_t*>(data);
    buffer_.insert(buffer_.end(), begin, begin + size);
  }
  void u32(uint32_t value) {
    for (int shift = 0; shift < 32; shift += 8) buffer_.push_back(uint8_t(value >> shift));
  }
  void u64(uint64_t value) {
    for (int shift = 0; shift < 64; shift += 8) buffer_.push_back(uint8_t(value >> shift));
  }
  void f32(float value) {
    uint32_t bits = 0;
    std::memcpy(&bits, &value, 4);
    u32(bits);
  }
  void f64(double value) {
    uint64_t bits = 0;
    std::memcpy(&bits, &value, 8);
    u64(bits);
  }
  void text(const std::string& value) {
    u32(static_cast<uint32_t>(value.size()));
    bytes(value.data(), value.size());
  }
  void floats(const float* values, size_t count) {
    buffer_.reserve(buffer_.size() + 4 * count);
    for (size_t i = 0; i < count; ++i) f32(values[i]);
  }

  const uint8_t* data() const { return buffer_.data(); }
  size_t size() const { return buffer_.size(); }

 private:
  std::vector<uint8_t> buffer_;
};

/// Every read returns false, and reads nothing, when fewer bytes remain than it needs.
class LittleEndianReader {
 public:
  LittleEndianReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  bool skip(size_t count) {
    if (remaining() < count) return false;
    position_ += count;
    return true;
  }
  bool u32(uint32_t* value) {
    if (remaining() < 4) return false;
    *value = 0;
    for (int i = 0; i < 4; ++i) *value |= uint32_t(data_[position_ + i]) << (8 * i);
    position_ += 4;
    return true;
  }
  bool u64(uint64_t* value) {
    if (remaining() < 8) return false;
    *value = 0;
    for (int i = 0; i < 8; ++i) *value |= uint64_t(data_[position_ + i]) << (8 * i);
    position_ += 8;
    return true;
  }
  bool f32(float* value) {
    uint32_t bits = 0;
    if (!u32(&bits)) return false;
    std::memcpy(value, &bits, 4);
    return true;
  }
  bool f64(double* value) {
    uint64_t bits = 0;
    if (!u64(&bits)) return false;
    std::memcpy(value, &bits, 8);
    return true;
  }
  bool text(std::string* value, size_t max_size = 1u << 16) {
    uint32_t size = 0;
    const size_t start = position_;
    if (!u32(&size) || size > max_size || remaining() < size) {
      position_ = start;
      return false;
    }
    value->assign(reinterpret_cast<const char*>(data_ + position_), size);
    position_ += size;
    return true;
  }
  bool floats(float* values, size_t count) {
    if (remaining() / 4 < count) return false;
    for (size_t i = 0; i < count; ++i) f32(&values[i]);
    return true;
  }

  size_t remaining() const { return size_ - position_; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t position_ = 0;
};

}  // namespace landmark_loop_closure
