// MATLAB v5 .mat reading for ground-truth matrices (format: MathWorks "MAT-File Format", v5).
#include <algorithm>
#include <cstring>
#include <fstream>
#include <memory>

#include <zlib.h>

#include "landmark_loop_closure/eval/ground_truth.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

// Data types and array classes of the format.
enum : uint32_t {
  kMiInt8 = 1,
  kMiUint8 = 2,
  kMiInt16 = 3,
  kMiUint16 = 4,
  kMiInt32 = 5,
  kMiUint32 = 6,
  kMiSingle = 7,
  kMiDouble = 9,
  kMiInt64 = 12,
  kMiUint64 = 13,
  kMiMatrix = 14,
  kMiCompressed = 15,
  kMiUtf8 = 16,
};
enum : uint32_t { kClassSparse = 5, kClassDouble = 6, kClassUint64 = 15 };
constexpr size_t kHeaderBytes = 128;
constexpr size_t kChunkBytes = 1 << 20;

// Sequential bytes, from the file or from an inflated compressed element.
class ByteReader {
 public:
  virtual ~ByteReader() = default;
  /// Reads exactly n bytes; false at a clean end before the first byte; throws when cut short.
  virtual bool read(void* out, size_t n) = 0;
  void skip(size_t n) {
    char buffer[4096];
    while (n > 0) {
      const size_t step = std::min(n, sizeof(buffer));
      require(read(buffer, step));
      n -= step;
    }
  }
  void require(bool ok) const {
    if (!ok) throw GroundTruthError("the file ends in the middle of a data element (truncated?)");
  }
};

class FileReader : public ByteReader {
 public:
  explicit FileReader(std::ifstream* file) : file_(file) {}
  bool read(void* out, size_t n) override {
    file_->read(static_cast<char*>(out), static_cast<std::streamsize>(n));
    const auto got = static_cast<size_t>(file_->gcount());
    if (got == 0 && n > 0) return false;
    if (got != n) throw GroundTruthError("the file is truncated");
    return true;
  }

 private:
  std::ifstream* file_;
};

class InflateReader : public ByteReader {
 public:
  InflateReader(std::ifstream* file, size_t compressed_bytes)
      : file_(file), remaining_(compressed_bytes), input_(kChunkBytes) {
    std::memset(&stream_, 0, sizeof(stream_));
    if (inflateInit(&stream_) != Z_OK) throw GroundTruthError("zlib could not start");
  }
  ~InflateReader() override { inflateEnd(&stream_); }

  bool read(void* out, size_t n) override {
    stream_.next_out = static_cast<Bytef*>(out);
    stream_.avail_out = static_cast<uInt>(n);
    while (stream_.avail_out > 0) {
      if (stream_.avail_in == 0) {
        if (remaining_ == 0 || finished_) break;
        const size_t step = std::min(remaining_, input_.size());
        file_->read(reinterpret_cast<char*>(input_.data()), static_cast<std::streamsize>(step));
        if (static_cast<size_t>(file_->gcount()) != step) {
          throw GroundTruthError("the file ends inside a compressed element (truncated?)");
        }
        remaining_ -= step;
        stream_.next_in = input_.data();
        stream_.avail_in = static_cast<uInt>(step);
      }
      const int status = inflate(&stream_, Z_NO_FLUSH);
      if (status == Z_STREAM_END) {
        finished_ = true;
        if (stream_.avail_out > 0) break;
      } else if (status != Z_OK) {
        throw GroundTruthError(std::string("a compressed element is corrupt (zlib: ") +
                               (stream_.msg ? stream_.msg : "error") + ")");
      }
    }
    const size_t got = n - stream_.avail_out;
    if (got == 0 && n > 0) return false;
    if (got != n) throw GroundTruthError("a compressed element ends early (corrupt?)");
    return true;
  }

 private:
  std::ifstream* file_;
  size_t remaining_;
  std::vector<Bytef> input_;
  z_stream stream_;
  bool finished_ = false;
};

struct Tag {
  uint32_t type = 0;
  uint32_t bytes = 0;
  bool small = false;  // Small element: data in the tag's last 4 bytes.
  uint8_t small_data[4] = {};
};

bool readTag(ByteReader* reader, Tag* tag) {
  uint32_t words[2];
  if (!reader->read(words, sizeof(words))) return false;
  if (words[0] >> 16) {
    tag->small = true;
    tag->type = words[0] & 0xffff;
    tag->bytes = words[0] >> 16;
    std::memcpy(tag->small_data, &words[1], 4);
  } else {
    tag->small = false;
    tag->type = words[0];
    tag->bytes = words[1];
  }
  return true;
}

size_t padding(const Tag& tag) { return tag.small ? 0 : (8 - tag.bytes % 8) % 8; }

std::vector<uint8_t> readPayload(ByteReader* reader, const Tag& tag) {
  std::vector<uint8_t> data(tag.bytes);
  if (tag.small) {
    std::memcpy(data.data(), tag.small_data, tag.bytes);
  } else {
    reader->require(reader->read(data.data(), tag.bytes));
    reader->skip(padding(tag));
  }
  return data;
}

size_t elementSize(uint32_t type) {
  switch (type) {
    case kMiInt8:
    case kMiUint8:
    case kMiUtf8:
      return 1;
    case kMiInt16:
    case kMiUint16:
      return 2;
    case kMiInt32:
    case kMiUint32:
    case kMiSingle:
      return 4;
    case kMiDouble:
    case kMiInt64:
    case kMiUint64:
      return 8;
    default:
      return 0;
  }
}

bool isNonzero(const uint8_t* value, uint32_t type) {
  switch (type) {
    case kMiSingle: {
      float v;
      std::memcpy(&v, value, sizeof(v));
      return v != 0.0f;
    }
    case kMiDouble: {
      double v;
      std::memcpy(&v, value, sizeof(v));
      return v != 0.0;
    }
    default:
      for (size_t i = 0; i < elementSize(type); ++i) {
        if (value[i] != 0) return true;
      }
      return false;
  }
}

// Calls visit(index) for every nonzero value of a numeric sub-element, in storage order.
template <typename Visit>
void streamNonzeros(ByteReader* reader, const Tag& tag, Visit visit) {
  const size_t size = elementSize(tag.type);
  if (size == 0) throw GroundTruthError("unsupported value type " + std::to_string(tag.type));
  if (tag.small) {
    for (size_t i = 0; i * size < tag.bytes; ++i) {
      if (isNonzero(tag.small_data + i * size, tag.type)) visit(i);
    }
    return;
  }
  std::vector<uint8_t> chunk(kChunkBytes - kChunkBytes % size);
  size_t index = 0;
  for (size_t left = tag.bytes; left > 0;) {
    const size_t step = std::min(left, chunk.size());
    reader->require(reader->read(chunk.data(), step));
    for (size_t offset = 0; offset < step; offset += size, ++index) {
      if (isNonzero(chunk.data() + offset, tag.type)) visit(index);
    }
    left -= step;
  }
  reader->skip(padding(tag));
}

std::vector<int64_t> readIntegers(ByteReader* reader, const Tag& tag) {
  const std::vector<uint8_t> data = readPayload(reader, tag);
  std::vector<int64_t> values;
  if (tag.type == kMiInt32 || tag.type == kMiUint32) {
    for (size_t i = 0; i + 4 <= data.size(); i += 4) {
      int32_t v;
      std::memcpy(&v, data.data() + i, 4);
      values.push_back(v);
    }
  } else if (tag.type == kMiInt64 || tag.type == kMiUint64) {
    for (size_t i = 0; i + 8 <= data.size(); i += 8) {
      int64_t v;
      std::memcpy(&v, data.data() + i, 8);
      values.push_back(v);
    }
  } else {
    throw GroundTruthError("unexpected integer type " + std::to_string(tag.type));
  }
  return values;
}

// Parses the body of a miMATRIX element. Returns true and fills `truth` when it is the wanted
// 2-D numeric matrix; false (having read only part of it) otherwise, with its name in `name`.
bool readMatrix(ByteReader* reader, const std::string& wanted, std::string* name,
                GroundTruth* truth) {
  Tag tag;
  reader->require(readTag(reader, &tag));
  const std::vector<uint8_t> flags = readPayload(reader, tag);
  if (flags.size() < 4) throw GroundTruthError("array flags are missing");
  const uint32_t array_class = flags[0];
  reader->require(readTag(reader, &tag));
  const std::vector<int64_t> dims = readIntegers(reader, tag);
  reader->require(readTag(reader, &tag));
  const std::vector<uint8_t> name_bytes = readPayload(reader, tag);
  name->assign(name_bytes.begin(), name_bytes.end());

  const bool numeric = array_class >= kClassDouble && array_class <= kClassUint64;
  if ((!numeric && array_class != kClassSparse) || dims.size() != 2) return false;
  if (!wanted.empty() && *name != wanted) return false;
  const size_t rows = static_cast<size_t>(dims[0]);
  const size_t cols = static_cast<size_t>(dims[1]);
  *truth = GroundTruth(rows, cols);

  if (array_class == kClassSparse) {
    reader->require(readTag(reader, &tag));
    const std::vector<int64_t> row_index = readIntegers(reader, tag);
    reader->require(readTag(reader, &tag));
    const std::vector<int64_t> column_start = readIntegers(reader, tag);
    if (column_start.size() != cols + 1) throw GroundTruthError("sparse column index is malformed");
    reader->require(readTag(reader, &tag));
    size_t column = 0;
    streamNonzeros(reader, tag, [&](size_t k) {
      while (column < cols && static_cast<int64_t>(k) >= column_start[column + 1]) ++column;
      if (k >= row_index.size()) throw GroundTruthError("sparse values outnumber row indices");
      truth->add(static_cast<size_t>(row_index[k]), column);
    });
  } else {
    reader->require(readTag(reader, &tag));
    if (tag.bytes / std::max<size_t>(1, elementSize(tag.type)) != rows * cols) {
      throw GroundTruthError("'" + *name + "' holds " + std::to_string(tag.bytes) + " bytes, not " +
                             std::to_string(rows) + " x " + std::to_string(cols) + " values");
    }
    // Column-major: value k is (k % rows, k / rows).
    streamNonzeros(reader, tag, [&](size_t k) { truth->add(k % rows, k / rows); });
  }
  truth->finalize();
  return true;
}

}  // namespace

GroundTruth readMatGroundTruth(const std::string& path, const std::string& variable) {
  try {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw GroundTruthError("cannot open the file");
    char header[kHeaderBytes];
    file.read(header, kHeaderBytes);
    if (file.gcount() != static_cast<std::streamsize>(kHeaderBytes) ||
        std::strncmp(header, "MATLAB 5.0 MAT-file", 19) != 0) {
      throw GroundTruthError("not a MATLAB v5 .mat file (v7.3 files are HDF5: save with -v7)");
    }
    if (header[126] != 'I' || header[127] != 'M') {
      throw GroundTruthError("big-endian .mat files are not supported");
    }
    std::vector<std::string> seen;
    FileReader top(&file);
    Tag tag;
    while (readTag(&top, &tag)) {
      const std::streampos body = file.tellg();
      std::string name;
      GroundTruth truth;
      bool found = false;
      if (tag.type == kMiCompressed) {
        InflateReader inflated(&file, tag.bytes);
        Tag inner;
        inflated.require(readTag(&inflated, &inner));
        if (inner.type == kMiMatrix) found = readMatrix(&inflated, variable, &name, &truth);
      } else if (tag.type == kMiMatrix) {
        found = readMatrix(&top, variable, &name, &truth);
      }
      if (found) return truth;
      if (!name.empty()) seen.push_back(name);
      file.clear();
      file.seekg(body + static_cast<std::streamoff>(
                            tag.bytes + (tag.type == kMiCompressed ? 0 : padding(tag))));
    }
    std::string listing;
    for (const std::string& name : seen) listing += (listing.empty() ? "" : ", ") + name;
    throw GroundTruthError(variable.empty()
                               ? "no 2-D numeric matrix in the file"
                               : "no 2-D numeric variable '" + variable +
                                     "' (found: " + (listing.empty() ? "none" : listing) + ")");
  } catch (const GroundTruthError& error) {
    throw GroundTruthError(path + ": " + error.what());
  }
}

}  // namespace eval
}  // namespace landmark_loop_closure
