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

/// A keyframe as one byte string and back; decoding throws FormatError for damaged bytes.
std::vector<uint8_t> encodeKeyframe(const KeyframeRecord& keyframe);
KeyframeRecord decodeKeyframe(const uint8_t* data, size_t size);

}  // namespace database_payload
}  // namespace landmark_loop_closure
