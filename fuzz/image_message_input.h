#pragma once

// How fuzz_image_message reads its input as an image message; tests replay the kept inputs with it.

#include <cstdint>
#include <cstring>

#include <sensor_msgs/Image.h>

namespace landmark_loop_closure {
namespace fuzz {

/// Byte 0 picks the encoding from a list the node meets (good and bad); then little-endian u32
/// width, height and step (reduced to small ranges so that valid images come up too); the rest is
/// the pixel buffer.
inline sensor_msgs::Image imageFromBytes(const uint8_t* data, size_t size) {
  static const char* const kEncodings[] = {"mono8", "mono16", "bgr8",  "rgb8",
                                           "bgra8", "rgba8",  "16UC1", "32FC1",
                                           "8UC3",  "yuv422", "",      "bayer_rggb8"};
  sensor_msgs::Image image;
  if (size == 0) return image;
  image.encoding = kEncodings[data[0] % (sizeof(kEncodings) / sizeof(kEncodings[0]))];
  ++data;
  --size;
  const auto take = [&data, &size]() {
    uint32_t value = 0;
    const size_t n = size < 4 ? size : 4;
    std::memcpy(&value, data, n);
    data += n;
    size -= n;
    return value;
  };
  image.width = take() % 4097;
  image.height = take() % 4097;
  image.step = take() % 65536;
  image.data.assign(data, data + size);
  return image;
}

}  // namespace fuzz
}  // namespace landmark_loop_closure
