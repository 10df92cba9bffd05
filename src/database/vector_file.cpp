#include "database/vector_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "common/crc32c.h"
#include "database/database_payload.h"

namespace landmark_loop_closure {
namespace vector_file {

namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'V', 'E', 'C', '1', '\n'};
constexpr size_t kHeaderBytes = 8 + 4 + 8;
constexpr size_t kChunkBytes = 8 << 20;

std::runtime_error writeError(const std::string& path, const std::string& what) {
  return std::runtime_error("search rows " + path + ": " + what);
}

}  // namespace

uint32_t write(const std::string& path, const QuantizedVectors& vectors, size_t rows) {
  const std::string temporary = path + ".tmp";
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (file == nullptr) throw writeError(temporary, std::strerror(errno));
  uint8_t header[kHeaderBytes];
  std::memcpy(header, kMagic, 8);
  database_payload::encode(static_cast<uint32_t>(vectors.dimension()), header + 8);
  database_payload::encode(static_cast<uint64_t>(rows), header + 12);
  uint32_t crc = crc32c(0, header, kHeaderBytes);
  bool written = std::fwrite(header, 1, kHeaderBytes, file) == kHeaderBytes;
  for (size_t row = 0; written && row < rows; ++row) {
    crc = crc32c(crc, vectors.row(row), vectors.rowBytes());
    written = std::fwrite(vectors.row(row), 1, vectors.rowBytes(), file) == vectors.rowBytes();
  }
  written = written && std::fflush(file) == 0 && ::fsync(fileno(file)) == 0;
  const std::string reason = std::strerror(errno);
  written = std::fclose(file) == 0 && written;
  if (!written || std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw writeError(path, written ? std::strerror(errno) : reason);
  }
  return crc;
}

Reader::Reader(const std::string& path, uint32_t checksum, int dimension) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return;
  // The whole file is checked before a row is handed out: one sequential read, which also
  // brings it into the page cache for the second.
  std::vector<uint8_t> buffer(kChunkBytes);
  uint32_t crc = 0;
  uint64_t bytes = 0;
  size_t got = 0;
  while ((got = std::fread(buffer.data(), 1, buffer.size(), file)) > 0) {
    crc = crc32c(crc, buffer.data(), got);
    bytes += got;
  }
  uint8_t header[kHeaderBytes];
  const bool read_back = std::ferror(file) == 0 && crc == checksum && bytes >= kHeaderBytes &&
                         std::fseek(file, 0, SEEK_SET) == 0 &&
                         std::fread(header, 1, kHeaderBytes, file) == kHeaderBytes;
  if (!read_back || std::memcmp(header, kMagic, 8) != 0 ||
      database_payload::decode<uint32_t>(header + 8) != static_cast<uint32_t>(dimension)) {
    std::fclose(file);
    return;
  }
  row_bytes_ = sizeof(float) + static_cast<size_t>(dimension);
  rows_ = database_payload::decode<uint64_t>(header + 12);
  if (bytes != kHeaderBytes + rows_ * row_bytes_) {
    std::fclose(file);
    rows_ = 0;
    return;
  }
  file_ = file;
  chunk_.resize(std::max<size_t>(1, kChunkBytes / row_bytes_) * row_bytes_);
}

Reader::~Reader() {
  if (file_ != nullptr) std::fclose(file_);
}

const uint8_t* Reader::next() {
  if (file_ == nullptr || read_ >= rows_) return nullptr;
  if (chunk_next_ == chunk_rows_) {
    const size_t want =
        static_cast<size_t>(std::min<uint64_t>(rows_ - read_, chunk_.size() / row_bytes_));
    if (std::fread(chunk_.data(), row_bytes_, want, file_) != want) return nullptr;
    chunk_rows_ = want;
    chunk_next_ = 0;
  }
  ++read_;
  return chunk_.data() + row_bytes_ * chunk_next_++;
}

}  // namespace vector_file
}  // namespace landmark_loop_closure
