#pragma once

// One keyframe's fields: the map store's compact record and motion, and the old map file's
// layout (old_map_file.h), read for conversion. Private to the core library.

#include <cstdint>
#include <vector>

#include "database/database_payload.h"
#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {
namespace database_payload {

/// A keyframe in the old map file's layout (old_map_file.h); `version`: the file's (1 kept raw
/// thumbnails). Only read now, by `lcd_db convert`.
KeyframeRecord readKeyframe(PayloadReader* in, uint32_t version);
/// The same from one byte string (the map store's format 1 kept each keyframe so); throws
/// FormatError for damaged bytes.
KeyframeRecord decodeKeyframe(const uint8_t* data, size_t size);

/// The map store's record: what a keyframe holds beyond its summary and global vector (landmark
/// boxes and features, keypoints, ORB rows, 3D points, thumbnail), compactly: keypoints in 1/16
/// pixel, landmark features, 3D points and depth deviations in float16 (their accuracy is far
/// finer than a pixel or the depth noise). decodeRecord fills only those fields.
std::vector<uint8_t> encodeRecord(const KeyframeRecord& keyframe);
void decodeRecord(const uint8_t* data, size_t size, KeyframeRecord* keyframe);

/// A summary's pose and path (72 bytes) and back.
std::vector<uint8_t> encodeMotion(const KeyframeSummary& summary);
void decodeMotion(const uint8_t* data, size_t size, KeyframeSummary* summary);

}  // namespace database_payload
}  // namespace landmark_loop_closure
