#include "database/old_map_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "common/little_endian.h"
#include "database/database_payload.h"
#include "database/keyframe_codec.h"

namespace landmark_loop_closure {

namespace {

using database_payload::decode;
using database_payload::FormatError;
using database_payload::PayloadReader;

constexpr char kOldMapMagic[8] = {'L', 'L', 'C', 'K', 'F', 'D', 'B', '\n'};
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8 + 4;

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

void skipGraph(PayloadReader* in) {
  if (in->string().empty()) return;  // No graph was kept.
  const uint64_t size = in->u64();
  if (size > in->remaining()) throw FormatError("the graph is larger than the file");
  std::vector<uint8_t> chunk(64 << 10);
  for (uint64_t left = size; left > 0;) {
    const size_t part = static_cast<size_t>(std::min<uint64_t>(left, chunk.size()));
    in->bytes(chunk.data(), part);  // Read to be checksummed.
    left -= part;
  }
}

void checkRecordTable(PayloadReader* in, const std::vector<uint64_t>& offsets) {
  if (in->remaining() != 8 * (offsets.size() + 1)) {
    throw FormatError("the record table does not fill the end of the file");
  }
  for (size_t i = 0; i < offsets.size(); ++i) {
    if (in->u64() != offsets[i]) {
      throw FormatError("the record table disagrees with where keyframe " + std::to_string(i) +
                        " starts");
    }
  }
  if (in->u64() + 1 != offsets.size()) {
    throw FormatError("the record table counts other keyframes");
  }
}

}  // namespace

void readOldMapFile(const std::string& path,
                    const std::function<void(const OldMapFileHeader&)>& header,
                    const std::function<void(KeyframeRecord)>& each) {
  try {
    // O_NONBLOCK: a FIFO in the way is refused by fstat, not waited on.
    const FileDescriptor file(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK));
    if (file.get() < 0) throw FormatError(std::string("cannot open it: ") + std::strerror(errno));
    struct stat status {};
    if (::fstat(file.get(), &status) != 0) throw FormatError(std::strerror(errno));
    if (!S_ISREG(status.st_mode)) throw FormatError("not a regular file");
    const uint64_t file_bytes = static_cast<uint64_t>(status.st_size);
    if (file_bytes < kHeaderBytes) throw FormatError("truncated: shorter than the header");
    uint8_t bytes[kHeaderBytes];
    database_payload::readAt(file.get(), 0, bytes, kHeaderBytes);
    if (std::memcmp(bytes, kOldMapMagic, 8) != 0) throw FormatError("not a keyframe database file");
    const uint32_t version = decode<uint32_t>(bytes + 8);
    if (decode<uint32_t>(bytes + 12) != kByteOrderMark) {
      throw FormatError("byte-order mark is not little-endian 0x01020304");
    }
    if (version > kOldMapFileVersion) {
      throw FormatError("format version " + std::to_string(version) +
                        " is newer than this build reads (" + std::to_string(kOldMapFileVersion) +
                        ")");
    }
    if (version == 0) throw FormatError("format version 0 does not exist");
    const uint64_t payload_bytes = decode<uint64_t>(bytes + 16);
    const uint32_t expected_crc = decode<uint32_t>(bytes + 24);
    // Every length inside is checked against the payload's size, so it must be the real one.
    const uint64_t held = file_bytes - kHeaderBytes;
    if (payload_bytes != held) {
      throw FormatError(
          std::string(payload_bytes > held ? "truncated" : "bytes after the payload") +
          ": the header announces " + std::to_string(payload_bytes) +
          " payload bytes, the file holds " + std::to_string(held));
    }

    PayloadReader in(file.get(), kHeaderBytes, 0, payload_bytes);
    OldMapFileHeader prefix;
    prefix.descriptor_identity = in.string();
    prefix.global_dimension = static_cast<int>(in.u32());
    prefix.keyframes = in.u64();
    if (prefix.global_dimension <= 0) throw FormatError("global descriptors of no values");
    header(prefix);
    std::vector<uint64_t> offsets;
    for (uint64_t i = 0; i < prefix.keyframes; ++i) {
      if (version >= 3) offsets.push_back(in.position());
      KeyframeRecord keyframe = database_payload::readKeyframe(&in, version);
      if (keyframe.descriptor.global.size() != static_cast<size_t>(prefix.global_dimension)) {
        throw FormatError("keyframe " + std::to_string(keyframe.id) + " has " +
                          std::to_string(keyframe.descriptor.global.size()) +
                          " global values, the file " + std::to_string(prefix.global_dimension));
      }
      each(std::move(keyframe));
    }
    if (version >= 2) {
      if (version >= 3) offsets.push_back(in.position());
      skipGraph(&in);
    }
    if (version >= 3) checkRecordTable(&in, offsets);
    if (in.remaining() != 0) throw FormatError("bytes left over after the last keyframe");
    if (in.crc() != expected_crc) throw FormatError("checksum mismatch: the file is corrupt");
  } catch (const FormatError& error) {
    throw std::runtime_error("refused " + path + ": " + error.what());
  }
}

}  // namespace landmark_loop_closure
