#include "landmark_loop_closure/database_file.h"

#include "crc32c.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

namespace landmark_loop_closure {

namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'K', 'F', 'D', 'B', '\n'};
constexpr uint32_t kByteOrderMark = 0x01020304;
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8 + 4;
constexpr size_t kFileBuffer = 1 << 20;

bool hostIsLittleEndian() {
  const uint16_t probe = 1;
  uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

// CRC-32C of everything passed through it.
class Checksum {
 public:
  void update(const uint8_t* data, size_t size) { value_ = crc32c(value_, data, size); }
  uint32_t value() const { return value_; }

 private:
  uint32_t value_ = 0;
};

// Why a file cannot be read; caught at the top and turned into LoadedDatabase::error.
struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct FileCloser {
  void operator()(std::FILE* file) const {
    if (file) std::fclose(file);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

template <typename Unsigned>
void encode(Unsigned value, uint8_t* out) {
  for (size_t i = 0; i < sizeof(Unsigned); ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
}

template <typename Unsigned>
Unsigned decode(const uint8_t* in) {
  Unsigned value = 0;
  for (size_t i = 0; i < sizeof(Unsigned); ++i) value |= static_cast<Unsigned>(in[i]) << (8 * i);
  return value;
}

// Bytes of a matrix element in the file: elements are stored as the host's, swapped to little
// endian on big-endian hosts.
void swapElements(uint8_t* data, size_t bytes, size_t element) {
  if (element <= 1) return;
  for (size_t start = 0; start + element <= bytes; start += element) {
    for (size_t i = 0; i < element / 2; ++i)
      std::swap(data[start + i], data[start + element - 1 - i]);
  }
}

static_assert(sizeof(cv::Point2f) == 2 * sizeof(float) &&
                  sizeof(cv::Point3f) == 3 * sizeof(float) &&
                  sizeof(cv::Rect2f) == 4 * sizeof(float),
              "points and boxes are stored as their floats");

bool supportedMatType(int type) { return type == CV_8UC1 || type == CV_16FC1 || type == CV_32FC1; }

class PayloadWriter {
 public:
  explicit PayloadWriter(std::FILE* file) : file_(file) {}

  void bytes(const void* data, size_t size) {
    if (size == 0) return;
    const auto* bytes = static_cast<const uint8_t*>(data);
    chunk_.insert(chunk_.end(), bytes, bytes + size);
    written_ += size;
    if (chunk_.size() >= kFileBuffer * 4) flush();
  }
  /// Checksums and writes what is buffered; call before the header is written.
  void flush() {
    if (chunk_.empty()) return;
    crc_.update(chunk_.data(), chunk_.size());
    if (std::fwrite(chunk_.data(), 1, chunk_.size(), file_) != chunk_.size()) {
      throw FormatError(std::strerror(errno));
    }
    chunk_.clear();
  }
  void u32(uint32_t value) {
    uint8_t buffer[4];
    encode(value, buffer);
    bytes(buffer, 4);
  }
  void u64(uint64_t value) {
    uint8_t buffer[8];
    encode(value, buffer);
    bytes(buffer, 8);
  }
  void i32(int value) { u32(static_cast<uint32_t>(value)); }
  void f64(double value) {
    uint64_t bits = 0;
    std::memcpy(&bits, &value, 8);
    u64(bits);
  }
  void count(size_t value) {
    if (value > UINT32_MAX) throw FormatError("more than 2^32 items in one list");
    u32(static_cast<uint32_t>(value));
  }
  /// `n` floats in one write: the bulk of a keyframe (descriptors, keypoints, depths).
  void floats(const float* values, size_t n) {
    if (n == 0) return;
    std::vector<uint8_t> buffer(n * 4);
    std::memcpy(buffer.data(), values, n * 4);
    if (!hostIsLittleEndian()) swapElements(buffer.data(), buffer.size(), 4);
    bytes(buffer.data(), buffer.size());
  }
  void string(const std::string& text) {
    count(text.size());
    bytes(text.data(), text.size());
  }
  void mat(const cv::Mat& matrix) {
    if (!matrix.empty() && !supportedMatType(matrix.type())) {
      throw FormatError("cannot store a matrix of type " + std::to_string(matrix.type()));
    }
    i32(matrix.rows);
    i32(matrix.cols);
    i32(matrix.empty() ? CV_8UC1 : matrix.type());
    const size_t row_bytes = static_cast<size_t>(matrix.cols) * matrix.elemSize();
    std::vector<uint8_t> row(row_bytes);
    for (int r = 0; r < matrix.rows; ++r) {
      std::memcpy(row.data(), matrix.ptr(r), row_bytes);
      if (!hostIsLittleEndian()) swapElements(row.data(), row_bytes, matrix.elemSize1());
      bytes(row.data(), row_bytes);
    }
  }

  uint32_t crc() const { return crc_.value(); }
  uint64_t written() const { return written_; }

 private:
  std::FILE* file_;
  Checksum crc_;
  uint64_t written_ = 0;
  std::vector<uint8_t> chunk_;  ///< Fields gathered into large writes and checksum calls.
};

class PayloadReader {
 public:
  PayloadReader(std::FILE* file, uint64_t payload_bytes)
      : file_(file), remaining_(payload_bytes), unread_(payload_bytes) {}

  void bytes(void* out, size_t size) {
    if (size > remaining_) throw FormatError("an entry runs past the end of the payload");
    remaining_ -= size;
    auto* target = static_cast<uint8_t*>(out);
    while (size > 0) {
      if (position_ == chunk_.size()) refill();
      const size_t take = std::min(size, chunk_.size() - position_);
      std::memcpy(target, chunk_.data() + position_, take);
      position_ += take;
      target += take;
      size -= take;
    }
  }
  uint32_t u32() {
    uint8_t buffer[4];
    bytes(buffer, 4);
    return decode<uint32_t>(buffer);
  }
  uint64_t u64() {
    uint8_t buffer[8];
    bytes(buffer, 8);
    return decode<uint64_t>(buffer);
  }
  int i32() { return static_cast<int>(u32()); }
  double f64() {
    const uint64_t bits = u64();
    double value = 0.0;
    std::memcpy(&value, &bits, 8);
    return value;
  }
  /// A list length whose items take at least `item_bytes` each: refused when they cannot fit in
  /// what is left, before anything is allocated.
  size_t count(size_t item_bytes) {
    const uint64_t n = u32();
    if (n * item_bytes > remaining_) throw FormatError("a list is longer than the file");
    return static_cast<size_t>(n);
  }
  void floats(float* values, size_t n) {
    if (n == 0) return;
    bytes(values, n * 4);
    if (!hostIsLittleEndian()) swapElements(reinterpret_cast<uint8_t*>(values), n * 4, 4);
  }
  std::string string() {
    std::string text(count(1), '\0');
    bytes(text.data(), text.size());
    return text;
  }
  cv::Mat mat() {
    const int rows = i32();
    const int cols = i32();
    const int type = i32();
    if (rows < 0 || cols < 0 || !supportedMatType(type)) {
      throw FormatError("a matrix has a bad shape or type");
    }
    const uint64_t total = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) *
                           static_cast<uint64_t>(CV_ELEM_SIZE(type));
    if (total > remaining_) throw FormatError("a matrix is larger than the file");
    if (rows == 0 || cols == 0) return {};
    cv::Mat matrix(rows, cols, type);
    const size_t row_bytes = static_cast<size_t>(cols) * matrix.elemSize();
    for (int r = 0; r < rows; ++r) {
      bytes(matrix.ptr(r), row_bytes);
      if (!hostIsLittleEndian()) swapElements(matrix.ptr(r), row_bytes, matrix.elemSize1());
    }
    return matrix;
  }

  uint32_t crc() const { return crc_.value(); }
  uint64_t remaining() const { return remaining_; }

 private:
  // Reads the next chunk of the payload and checksums it whole (one call per megabytes, not
  // per field: loading is bound by memory speed, not by call overhead).
  void refill() {
    const size_t size = static_cast<size_t>(std::min<uint64_t>(unread_, kFileBuffer * 4));
    chunk_.resize(size);
    if (size == 0 || std::fread(chunk_.data(), 1, size, file_) != size) {
      throw FormatError("truncated: the file ends inside its payload");
    }
    crc_.update(chunk_.data(), size);
    unread_ -= size;
    position_ = 0;
  }

  std::FILE* file_;
  uint64_t remaining_;  ///< Payload bytes not yet handed out.
  uint64_t unread_;     ///< Payload bytes not yet read from the file.
  std::vector<uint8_t> chunk_;
  size_t position_ = 0;
  Checksum crc_;
};

void writePose(PayloadWriter* out, const Pose& pose) {
  for (int i = 0; i < 3; ++i) out->f64(pose.position[i]);
  out->f64(pose.orientation.w());
  out->f64(pose.orientation.x());
  out->f64(pose.orientation.y());
  out->f64(pose.orientation.z());
}

Pose readPose(PayloadReader* in) {
  Pose pose;
  for (int i = 0; i < 3; ++i) pose.position[i] = in->f64();
  const double w = in->f64();
  const double x = in->f64();
  const double y = in->f64();
  const double z = in->f64();
  pose.orientation = Eigen::Quaterniond(w, x, y, z);
  return pose;
}

void writeKeyframe(PayloadWriter* out, const KeyframeRecord& keyframe) {
  out->u64(keyframe.id);
  out->u32(keyframe.session);
  out->f64(keyframe.stamp);
  writePose(out, keyframe.pose);
  out->f64(keyframe.path.metres);
  out->f64(keyframe.path.radians);

  // Points and boxes are plain floats side by side (static_asserts below).
  const ImageDescriptor& descriptor = keyframe.descriptor;
  out->count(descriptor.global.size());
  out->floats(descriptor.global.data(), descriptor.global.size());
  out->count(descriptor.landmark_boxes.size());
  out->floats(reinterpret_cast<const float*>(descriptor.landmark_boxes.data()),
              4 * descriptor.landmark_boxes.size());
  out->mat(descriptor.landmark_features);

  const LocalFeatures& local = keyframe.local_features;
  out->count(local.points.size());
  out->floats(reinterpret_cast<const float*>(local.points.data()), 2 * local.points.size());
  out->mat(local.descriptors);
  out->i32(local.image_size.width);
  out->i32(local.image_size.height);
  out->count(local.points3d.size());
  out->floats(reinterpret_cast<const float*>(local.points3d.data()), 3 * local.points3d.size());
  out->count(local.depth_sd.size());
  out->floats(local.depth_sd.data(), local.depth_sd.size());

  out->count(keyframe.thumbnail_jpeg.size());
  out->bytes(keyframe.thumbnail_jpeg.data(), keyframe.thumbnail_jpeg.size());
}

KeyframeRecord readKeyframe(PayloadReader* in, uint32_t version) {
  KeyframeRecord keyframe;
  keyframe.id = in->u64();
  keyframe.session = in->u32();
  keyframe.stamp = in->f64();
  keyframe.pose = readPose(in);
  keyframe.path.metres = in->f64();
  keyframe.path.radians = in->f64();

  ImageDescriptor& descriptor = keyframe.descriptor;
  descriptor.global.resize(in->count(4));
  in->floats(descriptor.global.data(), descriptor.global.size());
  descriptor.landmark_boxes.resize(in->count(16));
  in->floats(reinterpret_cast<float*>(descriptor.landmark_boxes.data()),
             4 * descriptor.landmark_boxes.size());
  descriptor.landmark_features = in->mat();
  if (descriptor.landmark_features.rows != static_cast<int>(descriptor.landmark_boxes.size())) {
    throw FormatError("keyframe " + std::to_string(keyframe.id) +
                      ": landmark boxes and features disagree");
  }

  LocalFeatures& local = keyframe.local_features;
  local.points.resize(in->count(8));
  in->floats(reinterpret_cast<float*>(local.points.data()), 2 * local.points.size());
  local.descriptors = in->mat();
  local.image_size.width = in->i32();
  local.image_size.height = in->i32();
  local.points3d.resize(in->count(12));
  in->floats(reinterpret_cast<float*>(local.points3d.data()), 3 * local.points3d.size());
  local.depth_sd.resize(in->count(4));
  in->floats(local.depth_sd.data(), local.depth_sd.size());
  const size_t points = local.points.size();
  if (local.descriptors.rows != static_cast<int>(points) ||
      (!local.points3d.empty() && local.points3d.size() != points) ||
      local.depth_sd.size() != local.points3d.size()) {
    throw FormatError("keyframe " + std::to_string(keyframe.id) +
                      ": keypoints, descriptors and depths disagree");
  }

  if (version == 1) {
    keyframe.thumbnail_jpeg = encodeThumbnail(in->mat());  // Version 1 kept raw pixels.
  } else {
    keyframe.thumbnail_jpeg.resize(in->count(1));
    in->bytes(keyframe.thumbnail_jpeg.data(), keyframe.thumbnail_jpeg.size());
  }
  return keyframe;
}

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
    for (size_t i = 0; i < database.size(); ++i) writeKeyframe(&out, database.at(i));
    // The graph takes minutes to rebuild at 100 000 keyframes and milliseconds to read.
    if (database.graph()) {
      out.string(database.indexOptions().graphIdentity());
      const std::vector<uint8_t> graph = database.graph()->toBytes();
      out.u64(graph.size());
      out.bytes(graph.data(), graph.size());
    } else {
      out.string("");
    }
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
                            int global_dimension, const IndexOptions& index) {
  LoadedDatabase loaded;
  try {
    File file(std::fopen(path.c_str(), "rb"));
    if (!file) throw FormatError(std::string("cannot open it: ") + std::strerror(errno));
    std::setvbuf(file.get(), nullptr, _IOFBF, kFileBuffer);
    uint8_t header[kHeaderBytes];
    if (std::fread(header, 1, kHeaderBytes, file.get()) != kHeaderBytes) {
      throw FormatError("truncated: shorter than the header");
    }
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
    if (fseeko(file.get(), 0, SEEK_END) != 0) throw FormatError(std::strerror(errno));
    const off_t file_bytes = ftello(file.get());
    if (file_bytes < 0 || fseeko(file.get(), static_cast<off_t>(kHeaderBytes), SEEK_SET) != 0) {
      throw FormatError(std::strerror(errno));
    }
    const uint64_t held = static_cast<uint64_t>(file_bytes) - kHeaderBytes;
    if (payload_bytes != held) {
      throw FormatError(
          std::string(payload_bytes > held ? "truncated" : "bytes after the payload") +
          ": the header announces " + std::to_string(payload_bytes) +
          " payload bytes, the file holds " + std::to_string(held));
    }

    PayloadReader in(file.get(), payload_bytes);
    const std::string identity = in.string();
    if (identity != descriptor_identity) {
      throw FormatError("made with other descriptors (" + identity +
                        "), not the ones configured (" + descriptor_identity + ")");
    }
    const int dimension = static_cast<int>(in.u32());
    if (dimension != global_dimension) {
      throw FormatError("global descriptors have " + std::to_string(dimension) +
                        " values, the configured ones " + std::to_string(global_dimension));
    }
    IndexOptions exact;
    exact.type = "exact";  // The graph is read or built once every keyframe is in.
    KeyframeDatabase database(global_dimension, exact);
    const uint64_t keyframes = in.u64();
    for (uint64_t i = 0; i < keyframes; ++i) {
      KeyframeRecord keyframe = readKeyframe(&in, version);
      try {
        database.add(std::move(keyframe));
      } catch (const std::invalid_argument& error) {
        throw FormatError(error.what());
      }
    }
    std::string graph_identity;
    std::vector<uint8_t> graph_bytes;
    if (version >= 2) {
      graph_identity = in.string();
      if (!graph_identity.empty()) {
        const uint64_t size = in.u64();
        if (size > in.remaining()) throw FormatError("the graph is larger than the file");
        graph_bytes.resize(static_cast<size_t>(size));
        in.bytes(graph_bytes.data(), graph_bytes.size());
      }
    }
    if (in.remaining() != 0) throw FormatError("bytes left over after the last keyframe");
    if (in.crc() != expected_crc) throw FormatError("checksum mismatch: the file is corrupt");
    if (std::fgetc(file.get()) != EOF) throw FormatError("bytes after the payload");
    // Only checked bytes reach the graph reader.
    std::unique_ptr<ApproximateIndex> graph;
    if (index.buildsGraph() && graph_identity == index.graphIdentity()) {
      try {
        graph =
            ApproximateIndex::fromBytes(std::move(graph_bytes), global_dimension, index.neighbors);
      } catch (const std::runtime_error& error) {
        throw FormatError(error.what());
      }
      if (graph->size() != database.size()) {
        throw FormatError("the graph holds " + std::to_string(graph->size()) + " of " +
                          std::to_string(database.size()) + " keyframes");
      }
    }
    loaded.graph_rebuilt = index.buildsGraph() && !graph;
    database.setIndex(index, std::move(graph));
    loaded.database = std::move(database);
  } catch (const FormatError& error) {
    loaded.error = "refused " + path + ": " + error.what();
  }
  return loaded;
}

}  // namespace landmark_loop_closure
