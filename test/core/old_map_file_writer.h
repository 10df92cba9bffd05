#pragma once

// Writes a map file of the format before the map store (src/database/old_map_file.h, version 3),
// so the tests of `lcd_db convert` build their input. The product no longer writes this format.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../src/common/little_endian.h"
#include "../../src/database/database_payload.h"
#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

namespace old_map_file_test {

using database_payload::PayloadWriter;

inline void writeKeyframe(PayloadWriter* out, const KeyframeRecord& keyframe) {
  out->u64(keyframe.id);
  out->u32(keyframe.session);
  out->f64(keyframe.stamp);
  for (int i = 0; i < 3; ++i) out->f64(keyframe.pose.position[i]);
  const Eigen::Quaterniond& q = keyframe.pose.orientation;
  for (double value : {q.w(), q.x(), q.y(), q.z()}) out->f64(value);
  out->f64(keyframe.path.metres);
  out->f64(keyframe.path.radians);
  const ImageDescriptor& descriptor = keyframe.descriptor;
  out->count(descriptor.global.size());
  out->floats(descriptor.global.data(), descriptor.global.size());
  out->count(descriptor.landmark_boxes.size());
  out->floats(reinterpret_cast<const float*>(descriptor.landmark_boxes.data()),
              4 * descriptor.landmark_boxes.size());
  out->mat(descriptor.landmark_features);
  const LocalFeatures& local = keyframe.local_features;
  out->count(local.points.size());
  out->floats(reinterpret_cast<const float*>(local.points.data()), 2 * local.points.size());
  out->mat(local.descriptors);
  out->i32(local.image_size.width);
  out->i32(local.image_size.height);
  out->count(local.points3d.size());
  out->floats(reinterpret_cast<const float*>(local.points3d.data()), 3 * local.points3d.size());
  out->count(local.depth_sd.size());
  out->floats(local.depth_sd.data(), local.depth_sd.size());
  out->count(keyframe.thumbnail.size());
  out->bytes(keyframe.thumbnail.data(), keyframe.thumbnail.size());
}

inline void writeHeader(std::FILE* file, uint64_t payload_bytes, uint32_t crc) {
  uint8_t header[28];
  std::memcpy(header, "LLCKFDB\n", 8);
  database_payload::encode<uint32_t>(3, header + 8);
  database_payload::encode<uint32_t>(kByteOrderMark, header + 12);
  database_payload::encode<uint64_t>(payload_bytes, header + 16);
  database_payload::encode<uint32_t>(crc, header + 24);
  std::fseek(file, 0, SEEK_SET);
  std::fwrite(header, 1, sizeof(header), file);
}

}  // namespace old_map_file_test

/// Writes `keyframes` as a version-3 map file at `path` (no search graph kept).
inline void writeOldMapFile(const std::vector<KeyframeRecord>& keyframes,
                            const std::string& descriptor_identity, int global_dimension,
                            const std::string& path) {
  using namespace old_map_file_test;
  std::FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr) << path;
  writeHeader(file, 0, 0);  // Until the payload's size and checksum are known.
  PayloadWriter out(file);
  out.string(descriptor_identity);
  out.u32(static_cast<uint32_t>(global_dimension));
  out.u64(keyframes.size());
  std::vector<uint64_t> offsets;
  for (const KeyframeRecord& keyframe : keyframes) {
    offsets.push_back(out.written());
    writeKeyframe(&out, keyframe);
  }
  offsets.push_back(out.written());
  out.string("");  // No graph.
  for (const uint64_t offset : offsets) out.u64(offset);
  out.u64(keyframes.size());
  out.flush();
  writeHeader(file, out.written(), out.crc());
  ASSERT_EQ(std::fclose(file), 0);
}

}  // namespace landmark_loop_closure
