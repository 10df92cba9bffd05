#pragma once

// One keyframe's fields in the payload layout (database_file.h describes it), shared by the map
// file and the keyframe store. Private to the core library.

#include <cstdint>
#include <vector>

#include "database/database_payload.h"
#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {
namespace database_payload {

void writeKeyframe(PayloadWriter* out, const KeyframeRecord& keyframe);
/// `version`: the map file's (1 kept raw thumbnails); the store writes the current layout.
KeyframeRecord readKeyframe(PayloadReader* in, uint32_t version);

/// A keyframe as one byte string and back, in the earlier map file's layout (what `lcd_db
/// convert` reads); decoding throws FormatError for damaged bytes.
std::vector<uint8_t> encodeKeyframe(const KeyframeRecord& keyframe);
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
