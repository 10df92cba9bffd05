#include "common/checksummed_file.h"

#include <cstring>
#include <fstream>

#include "common/crc32c.h"
#include "landmark_loop_closure/common/durable_file.h"

namespace landmark_loop_closure {

namespace {

constexpr size_t kHeaderBytes = 8 + 4 + 4;  // Magic, byte-order mark, version.

}  // namespace

void beginChecksummedFile(LittleEndianWriter* writer, const char (&magic)[8], uint32_t version) {
  writer->bytes(magic, sizeof(magic));
  writer->u32(kByteOrderMark);
  writer->u32(version);
}

std::string finishChecksummedFile(const std::string& path, LittleEndianWriter* writer) {
  writer->u32(crc32c(0, writer->data(), writer->size()));
  return writeFileDurably(path, writer->data(), writer->size());
}

std::string readChecksummedFile(const std::string& path, const char (&magic)[8], uint32_t version,
                                const std::string& kind, std::vector<uint8_t>* body) {
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file) return "cannot be opened";
  // Read in one call: the map's saved summaries are ~92 MB at 1 000 000 keyframes.
  const std::streamoff size = file.tellg();
  if (size < 0) return "cannot be read";
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  file.seekg(0);
  if (!file.read(reinterpret_cast<char*>(bytes.data()), size)) return "cannot be read";
  if (bytes.size() < kHeaderBytes + 4 || std::memcmp(bytes.data(), magic, sizeof(magic)) != 0) {
    return "not a " + kind + " file";
  }
  uint32_t stored_crc = 0;
  LittleEndianReader(bytes.data() + bytes.size() - 4, 4).u32(&stored_crc);
  if (crc32c(0, bytes.data(), bytes.size() - 4) != stored_crc) {
    return "checksum mismatch (truncated or corrupt)";
  }
  LittleEndianReader header(bytes.data() + sizeof(magic), 8);
  uint32_t mark = 0, found_version = 0;
  header.u32(&mark);
  header.u32(&found_version);
  if (mark != kByteOrderMark) return "byte-order mark is not little-endian";
  if (found_version != version) {
    return "version " + std::to_string(found_version) + " is not " + std::to_string(version) +
           " (made by a newer release?)";
  }
  body->assign(bytes.begin() + kHeaderBytes, bytes.end() - 4);
  return "";
}

}  // namespace landmark_loop_closure
