#pragma once

// CRC-32C (Castagnoli), the checksum of the keyframe database file: the SSE4.2 instruction where
// the CPU has it (about 20 times faster than a byte-wise table), a slicing-by-8 table elsewhere.

#include <cstddef>
#include <cstdint>

namespace landmark_loop_closure {

/// Extends `crc` (0 to start) over `size` bytes; the result is the CRC-32C of all bytes so far.
uint32_t crc32c(uint32_t crc, const uint8_t* data, size_t size);

/// The same without the CPU instruction (for tests and other CPUs).
uint32_t crc32cPortable(uint32_t crc, const uint8_t* data, size_t size);

/// The CRC-32C of A followed by B from crc32c(0, A) and crc32c(0, B) and B's length: parts of a
/// file checksummed on separate threads give the checksum of the whole.
uint32_t crc32cCombine(uint32_t crc_first, uint32_t crc_second, uint64_t second_bytes);

}  // namespace landmark_loop_closure
