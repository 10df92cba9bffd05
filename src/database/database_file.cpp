#include "landmark_loop_closure/database/database_file.h"

#include "common/crc32c.h"
#include "common/little_endian.h"
#include "database/database_payload.h"
#include "database/keyframe_codec.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

namespace landmark_loop_closure {

namespace {

using database_payload::decode;
using database_payload::encode;
using database_payload::FormatError;
using database_payload::PayloadReader;
using database_payload::PayloadWriter;

constexpr char kMagic[8] = {'L', 'L', 'C', 'K', 'F', 'D', 'B', '\n'};
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8 + 4;
constexpr size_t kFileBuffer = 1 << 20;
// Below this many record bytes per thread, one thread reads faster than several start.
constexpr uint64_t kMinBytesPerThread = 8 << 20;

struct FileCloser {
  void operator()(std::FILE* file) const {
    if (file) std::fclose(file);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

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

void writeHeader(std::FILE* file, uint64_t payload_bytes, uint32_t crc) {
  uint8_t header[kHeaderBytes];
  std::memcpy(header, kMagic, 8);
  encode(kDatabaseFileVersion, header + 8);
  encode(kByteOrderMark, header + 12);
  encode(payload_bytes, header + 16);
  encode(crc, header + 24);
  if (std::fseek(file, 0, SEEK_SET) != 0 ||
      std::fwrite(header, 1, kHeaderBytes, file) != kHeaderBytes) {
    throw FormatError(std::strerror(errno));
  }
}

// What a file's payload holds, read and checksummed but not yet checked against the database
// it becomes.
struct Payload {
  std::vector<KeyframeRecord> keyframes;
  std::string graph_identity;
  std::vector<uint8_t> graph_bytes;
  uint32_t crc = 0;
};

// Descriptor identity, global dimension and keyframe count at the payload's start.
uint64_t readPrefix(PayloadReader* in, const std::string& descriptor_identity,
                    int global_dimension) {
  const std::string identity = in->string();
  if (identity != descriptor_identity) {
    throw FormatError("made with other descriptors (" + identity + "), not the ones configured (" +
                      descriptor_identity + ")");
  }
  const int dimension = static_cast<int>(in->u32());
  if (dimension != global_dimension) {
    throw FormatError("global descriptors have " + std::to_string(dimension) +
                      " values, the configured ones " + std::to_string(global_dimension));
  }
  return in->u64();
}

// The graph's settings and bytes after the last keyframe (version 2 on).
void readGraph(PayloadReader* in, Payload* payload) {
  payload->graph_identity = in->string();
  if (payload->graph_identity.empty()) return;
  const uint64_t size = in->u64();
  if (size > in->remaining()) throw FormatError("the graph is larger than the file");
  payload->graph_bytes.resize(static_cast<size_t>(size));
  in->bytes(payload->graph_bytes.data(), payload->graph_bytes.size());
}

// Versions 1 and 2: one reader from the first byte to the last.
Payload readSequentially(int fd, uint64_t payload_bytes, uint32_t version,
                         const std::string& descriptor_identity, int global_dimension) {
  Payload payload;
  PayloadReader in(fd, kHeaderBytes, 0, payload_bytes);
  const uint64_t keyframes = readPrefix(&in, descriptor_identity, global_dimension);
  for (uint64_t i = 0; i < keyframes; ++i) payload.keyframes.push_back(readKeyframe(&in, version));
  if (version >= 2) readGraph(&in, &payload);
  if (in.remaining() != 0) throw FormatError("bytes left over after the last keyframe");
  payload.crc = in.crc();
  return payload;
}

// Consecutive keyframes [first, last) read by one thread.
struct RecordRange {
  size_t first = 0;
  size_t last = 0;
  std::vector<KeyframeRecord> keyframes;
  uint32_t crc = 0;
  std::string error;
};

void readRange(int fd, const std::vector<uint64_t>& offsets, uint32_t version, RecordRange* range) {
  try {
    PayloadReader in(fd, kHeaderBytes, offsets[range->first], offsets[range->last]);
    range->keyframes.reserve(range->last - range->first);
    for (size_t i = range->first; i < range->last; ++i) {
      range->keyframes.push_back(readKeyframe(&in, version));
      if (in.position() != offsets[i + 1]) {
        throw FormatError("keyframe record " + std::to_string(i) +
                          " does not end where the record table says");
      }
    }
    range->crc = in.crc();
  } catch (const std::exception& error) {  // Reported by the loading thread.
    range->error = error.what();
  }
}

// Version 3 on: the record table at the payload's end says where each keyframe starts, so
// ranges of keyframes are read and checksummed by several threads at once; the checksums of
// the parts combine into the payload's.
Payload readInParallel(int fd, uint64_t payload_bytes, uint32_t version,
                       const std::string& descriptor_identity, int global_dimension,
                       int max_threads) {
  // Table: (keyframes + 1) u64 record offsets (the last is the graph's), then u64 keyframes.
  if (payload_bytes < 16) throw FormatError("truncated: no room for the record table");
  uint8_t count_bytes[8];
  database_payload::readAt(fd, kHeaderBytes + payload_bytes - 8, count_bytes, 8);
  const uint64_t keyframes = decode<uint64_t>(count_bytes);
  if (keyframes > (payload_bytes - 8) / 8 - 1) {
    throw FormatError("the record table is longer than the file");
  }
  const uint64_t table_bytes = 8 * (keyframes + 1);
  const uint64_t table_start = payload_bytes - 8 - table_bytes;
  std::vector<uint8_t> table(static_cast<size_t>(table_bytes));
  database_payload::readAt(fd, kHeaderBytes + table_start, table.data(), table.size());
  std::vector<uint64_t> offsets(keyframes + 1);
  for (size_t i = 0; i < offsets.size(); ++i) {
    offsets[i] = decode<uint64_t>(table.data() + 8 * i);
    if (offsets[i] > table_start || (i > 0 && offsets[i] < offsets[i - 1])) {
      throw FormatError("the record table points outside the keyframes");
    }
  }
  const uint32_t table_crc =
      crc32c(crc32c(0, table.data(), table.size()), count_bytes, sizeof(count_bytes));

  Payload payload;
  PayloadReader prefix(fd, kHeaderBytes, 0, offsets.front());
  if (readPrefix(&prefix, descriptor_identity, global_dimension) != keyframes) {
    throw FormatError("the keyframe count disagrees with the record table");
  }
  if (prefix.remaining() != 0) throw FormatError("bytes between the header and the keyframes");

  // Ranges of about equal bytes; the loading thread also reads the graph, so its range is
  // shorter by the graph's bytes.
  const uint64_t record_bytes = offsets.back() - offsets.front();
  const uint64_t graph_bytes = table_start - offsets.back();
  size_t threads = max_threads > 0
                       ? static_cast<size_t>(max_threads)
                       : std::max<size_t>(1, std::min<uint64_t>(std::thread::hardware_concurrency(),
                                                                record_bytes / kMinBytesPerThread));
  threads = std::max<size_t>(1, std::min<size_t>(threads, keyframes));
  const double share = static_cast<double>(record_bytes + graph_bytes) / threads;
  std::vector<RecordRange> ranges(threads);
  size_t next = 0;
  for (size_t t = 0; t < threads; ++t) {
    ranges[t].first = next;
    const double end = offsets.front() + share * (t + 1) - static_cast<double>(graph_bytes);
    while (next < keyframes && (t + 1 == threads || static_cast<double>(offsets[next]) < end)) {
      ++next;
    }
    ranges[t].last = next;
  }
  std::vector<std::thread> workers;
  for (size_t t = 1; t < threads; ++t) {
    try {
      workers.emplace_back(readRange, fd, std::cref(offsets), version, &ranges[t]);
    } catch (const std::system_error&) {  // No thread to be had: read this range here.
      readRange(fd, offsets, version, &ranges[t]);
    }
  }
  readRange(fd, offsets, version, &ranges[0]);
  std::string graph_error;
  PayloadReader graph(fd, kHeaderBytes, offsets.back(), table_start);
  try {
    readGraph(&graph, &payload);
    if (graph.remaining() != 0) throw FormatError("bytes left over after the graph");
  } catch (const std::exception& error) {
    graph_error = error.what();
  }
  for (std::thread& worker : workers) worker.join();

  payload.crc = prefix.crc();
  for (RecordRange& range : ranges) {
    if (!range.error.empty()) throw FormatError(range.error);
    payload.crc = crc32cCombine(payload.crc, range.crc, offsets[range.last] - offsets[range.first]);
  }
  if (!graph_error.empty()) throw FormatError(graph_error);
  payload.crc = crc32cCombine(payload.crc, graph.crc(), graph_bytes);
  payload.crc = crc32cCombine(payload.crc, table_crc, table_bytes + 8);
  payload.keyframes.reserve(keyframes);
  for (RecordRange& range : ranges) {
    for (KeyframeRecord& keyframe : range.keyframes)
      payload.keyframes.push_back(std::move(keyframe));
    range.keyframes = {};
  }
  return payload;
}

}  // namespace

std::string saveDatabase(const KeyframeDatabase& database, const std::string& descriptor_identity,
                         const std::string& path) {
  const std::string temporary = path + ".tmp";
  try {
    File file(std::fopen(temporary.c_str(), "wb"));
    if (!file) throw FormatError(std::string("cannot create it: ") + std::strerror(errno));
    std::setvbuf(file.get(), nullptr, _IOFBF, kFileBuffer);
    writeHeader(file.get(), 0, 0);  // Placeholder until the payload's size and CRC are known.
    PayloadWriter out(file.get());
    out.string(descriptor_identity);
    out.u32(static_cast<uint32_t>(database.globalDimension()));
    out.u64(database.size());
    std::vector<uint64_t> offsets;
    offsets.reserve(database.size() + 1);
    for (size_t i = 0; i < database.size(); ++i) {
      offsets.push_back(out.written());
      const std::shared_ptr<const KeyframeRecord> keyframe = database.record(i);
      if (!keyframe) throw FormatError("keyframe " + std::to_string(i) + " cannot be read");
      writeKeyframe(&out, *keyframe);
    }
    offsets.push_back(out.written());
    out.string("");  // The graph lives beside the map store now; this format keeps none.
    for (const uint64_t offset : offsets) out.u64(offset);
    out.u64(database.size());
    out.flush();
    writeHeader(file.get(), out.written(), out.crc());
    if (std::fflush(file.get()) != 0 || ::fsync(fileno(file.get())) != 0) {
      throw FormatError(std::strerror(errno));
    }
    std::FILE* raw = file.release();
    if (std::fclose(raw) != 0) throw FormatError(std::strerror(errno));
  } catch (const FormatError& error) {
    std::remove(temporary.c_str());
    return "cannot write " + temporary + ": " + error.what();
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    return "cannot rename " + temporary + " to " + path + ": " + reason;
  }
  return "";
}

LoadedDatabase loadDatabase(const std::string& path, const std::string& descriptor_identity,
                            int global_dimension, const IndexOptions& index, int max_threads) {
  LoadedDatabase loaded;
  try {
    const FileDescriptor file(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (file.get() < 0) throw FormatError(std::string("cannot open it: ") + std::strerror(errno));
    struct stat status {};
    if (::fstat(file.get(), &status) != 0) throw FormatError(std::strerror(errno));
    if (!S_ISREG(status.st_mode)) throw FormatError("not a regular file");
    const uint64_t file_bytes = static_cast<uint64_t>(status.st_size);
    if (file_bytes < kHeaderBytes) throw FormatError("truncated: shorter than the header");
    uint8_t header[kHeaderBytes];
    database_payload::readAt(file.get(), 0, header, kHeaderBytes);
    if (std::memcmp(header, kMagic, 8) != 0) throw FormatError("not a keyframe database file");
    const uint32_t version = decode<uint32_t>(header + 8);
    const uint32_t byte_order = decode<uint32_t>(header + 12);
    if (byte_order != kByteOrderMark) {
      throw FormatError("byte-order mark is not little-endian 0x01020304");
    }
    if (version > kDatabaseFileVersion) {
      throw FormatError("format version " + std::to_string(version) +
                        " is newer than this build reads (" + std::to_string(kDatabaseFileVersion) +
                        ")");
    }
    if (version == 0) throw FormatError("format version 0 does not exist");
    const uint64_t payload_bytes = decode<uint64_t>(header + 16);
    const uint32_t expected_crc = decode<uint32_t>(header + 24);
    // Every length inside is checked against the payload's size, so it must be the real one.
    const uint64_t held = file_bytes - kHeaderBytes;
    if (payload_bytes != held) {
      throw FormatError(
          std::string(payload_bytes > held ? "truncated" : "bytes after the payload") +
          ": the header announces " + std::to_string(payload_bytes) +
          " payload bytes, the file holds " + std::to_string(held));
    }

    Payload payload = version >= 3
                          ? readInParallel(file.get(), payload_bytes, version, descriptor_identity,
                                           global_dimension, max_threads)
                          : readSequentially(file.get(), payload_bytes, version,
                                             descriptor_identity, global_dimension);
    if (payload.crc != expected_crc) throw FormatError("checksum mismatch: the file is corrupt");
    // Only checked bytes reach the database and the graph reader.
    IndexOptions exact;
    exact.type = "exact";  // The graph is read or built once every keyframe is in.
    KeyframeDatabase database(global_dimension, exact);
    for (KeyframeRecord& keyframe : payload.keyframes) {
      try {
        database.add(std::move(keyframe));
      } catch (const std::invalid_argument& error) {
        throw FormatError(error.what());
      }
    }
    payload.keyframes = {};
    // A graph stored in the file was faiss's, over float vectors: built again over 8-bit rows.
    loaded.graph_rebuilt = index.buildsGraph();
    database.setIndex(index);
    loaded.database = std::move(database);
  } catch (const FormatError& error) {
    loaded.error = "refused " + path + ": " + error.what();
  }
  return loaded;
}

std::string readDatabaseFileIdentity(const std::string& path, std::string* descriptor_identity,
                                     int* global_dimension) {
  try {
    const FileDescriptor file(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK));
    if (file.get() < 0) throw FormatError(std::string("cannot open it: ") + std::strerror(errno));
    struct stat status {};
    if (::fstat(file.get(), &status) != 0 || !S_ISREG(status.st_mode)) {
      throw FormatError("not a regular file");
    }
    const uint64_t file_bytes = static_cast<uint64_t>(status.st_size);
    if (file_bytes < kHeaderBytes) throw FormatError("truncated: shorter than the header");
    uint8_t header[kHeaderBytes];
    database_payload::readAt(file.get(), 0, header, kHeaderBytes);
    if (std::memcmp(header, kMagic, 8) != 0) throw FormatError("not a keyframe database file");
    PayloadReader in(file.get(), kHeaderBytes, 0, file_bytes - kHeaderBytes);
    *descriptor_identity = in.string();
    *global_dimension = static_cast<int>(in.u32());
  } catch (const FormatError& error) {
    return "refused " + path + ": " + error.what();
  }
  return "";
}

}  // namespace landmark_loop_closure
