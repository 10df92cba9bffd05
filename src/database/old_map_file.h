#pragma once

// The map file of the format before the map store (KeyframeStore::isOldMapFile recognises it),
// read once by `lcd_db convert`. Private to
// the core library.
//
// Little-endian throughout:
//   header: magic "LLCKFDB\n", u32 version, u32 byte-order mark 0x01020304, u64 payload bytes,
//           u32 CRC-32C (Castagnoli) of the payload;
//   payload: descriptor identity, u32 global dimension, u64 keyframes, then each keyframe
//           (keyframe_codec.h readKeyframe's layout); from version 2 a search graph (its settings,
//           empty when none, u64 bytes and the bytes), skipped; in version 3 last a record table
//           ((keyframes + 1) u64 offsets and u64 keyframes), checked against where each
//           keyframe ended.
// Strings and vectors are a u32 count then the items; matrices are i32 rows, cols and type, then
// the elements row by row.

#include <cstdint>
#include <functional>
#include <string>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

constexpr uint32_t kOldMapFileVersion = 3;

struct OldMapFileHeader {
  std::string descriptor_identity;
  int global_dimension = 0;
  uint64_t keyframes = 0;
};

/// Reads `path` from its first byte to its last, handing on its header, then each keyframe in
/// order. Lengths inside are checked against the bytes left before anything is allocated; the
/// checksum can only be compared at the end, so `each` must write into something its caller can
/// discard. Throws std::runtime_error("refused PATH: why") for a missing, truncated, corrupt,
/// newer or foreign file.
void readOldMapFile(const std::string& path,
                    const std::function<void(const OldMapFileHeader&)>& header,
                    const std::function<void(KeyframeRecord)>& each);

}  // namespace landmark_loop_closure
