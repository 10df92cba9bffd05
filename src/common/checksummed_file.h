#pragma once

// The layout of the package's model files (whitening, broad autoencoder) and of a map's saved
// summaries: 8-byte magic,
// byte-order mark, version, the body, then the CRC-32C of everything before it; written through
// DurableFile, so a crash or a full disk never leaves half a file under the real name.

#include <cstdint>
#include <string>
#include <vector>

#include "common/little_endian.h"

namespace landmark_loop_closure {

/// Starts a file: magic, byte-order mark, version.
void beginChecksummedFile(LittleEndianWriter* writer, const char (&magic)[8], uint32_t version);

/// Appends the checksum and writes the file atomically and durably (durable_file.h). Returns ""
/// or what failed; the earlier file is then as it was.
std::string finishChecksummedFile(const std::string& path, LittleEndianWriter* writer);

/// Reads a whole file, checks magic, checksum, byte-order mark and version; `body` receives the
/// bytes between the header and the checksum. Returns "" or what is wrong; `kind` names the file
/// type in messages ("not a <kind> file").
std::string readChecksummedFile(const std::string& path, const char (&magic)[8], uint32_t version,
                                const std::string& kind, std::vector<uint8_t>* body);

}  // namespace landmark_loop_closure
