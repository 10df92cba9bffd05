#include "database/vector_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "common/crc32c.h"
#include "database/database_payload.h"
#include "database/keyframe_codec.h"

namespace landmark_loop_closure {
namespace vector_file {

namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'V', 'E', 'C', '2', '\n'};
constexpr size_t kHeaderBytes = 8 + 4 + 4;
constexpr size_t kPieceBytes = 8 << 20;

std::runtime_error writeError(const std::string& path, const std::string& what) {
  return std::runtime_error("search rows " + path + ": " + what);
}

std::vector<uint8_t> header(int dimension) {
  std::vector<uint8_t> bytes(kHeaderBytes);
  std::memcpy(bytes.data(), kMagic, 8);
  database_payload::encode(static_cast<uint32_t>(dimension), bytes.data() + 8);
  database_payload::encode(static_cast<uint32_t>(kSummaryBytes), bytes.data() + 12);
  return bytes;
}

void encodeSummary(const KeyframeSummary& summary, uint8_t* out) {
  database_payload::encode(summary.id, out);
  database_payload::encode(summary.session, out + 8);
  uint64_t stamp_bits;
  std::memcpy(&stamp_bits, &summary.stamp, sizeof(stamp_bits));
  database_payload::encode(stamp_bits, out + 12);
  const std::vector<uint8_t> motion = database_payload::encodeMotion(summary);
  std::memcpy(out + 20, motion.data(), motion.size());
}

// CRC-32C of `size` bytes in pieces, so a mapped file is read front to back.
uint32_t checksum(uint32_t crc, const uint8_t* data, size_t size) {
  for (size_t done = 0; done < size; done += kPieceBytes) {
    crc = crc32c(crc, data + done, std::min(kPieceBytes, size - done));
  }
  return crc;
}

// Writes all of `bytes` at `offset`; false on an error (errno says which).
bool writeAt(int fd, const uint8_t* bytes, size_t size, off_t offset) {
  while (size > 0) {
    const ssize_t written = ::pwrite(fd, bytes, size, offset);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    bytes += written;
    size -= static_cast<size_t>(written);
    offset += written;
  }
  return true;
}

bool readAt(int fd, uint8_t* bytes, size_t size, off_t offset) {
  return ::pread(fd, bytes, size, offset) == static_cast<ssize_t>(size);
}

// Writes rows [from, rows) after the rows already in `fd`, then every summary after them. The
// seal's checksums continue from `seal` (rows from..) and start afresh (summaries).
bool writeTail(int fd, const QuantizedVectors& vectors, size_t from, size_t rows,
               const std::function<const KeyframeSummary&(size_t)>& summary_of, Seal* seal) {
  const size_t row_bytes = vectors.rowBytes();
  std::vector<uint8_t> buffer;
  buffer.reserve(kPieceBytes + row_bytes);
  off_t offset = static_cast<off_t>(kHeaderBytes + from * row_bytes);
  const auto flush = [&] {
    const bool written = writeAt(fd, buffer.data(), buffer.size(), offset);
    offset += static_cast<off_t>(buffer.size());
    buffer.clear();
    return written;
  };
  for (size_t row = from; row < rows; ++row) {
    seal->rows_checksum = crc32c(seal->rows_checksum, vectors.row(row), row_bytes);
    buffer.insert(buffer.end(), vectors.row(row), vectors.row(row) + row_bytes);
    if (buffer.size() >= kPieceBytes && !flush()) return false;
  }
  seal->summaries_checksum = 0;
  uint8_t summary[kSummaryBytes];
  for (size_t row = 0; row < rows; ++row) {
    encodeSummary(summary_of(row), summary);
    seal->summaries_checksum = crc32c(seal->summaries_checksum, summary, kSummaryBytes);
    buffer.insert(buffer.end(), summary, summary + kSummaryBytes);
    if (buffer.size() >= kPieceBytes && !flush()) return false;
  }
  seal->rows = rows;
  return flush() && ::ftruncate(fd, offset) == 0 && ::fsync(fd) == 0;
}

// Whether `fd` is the file `earlier` sealed, its rows the first of `vectors`' and its summaries
// theirs (the last of each compared).
bool continues(int fd, const Seal& earlier, const QuantizedVectors& vectors,
               const std::function<const KeyframeSummary&(size_t)>& summary_of) {
  const size_t row_bytes = vectors.rowBytes();
  struct stat status;
  if (earlier.rows == 0 || earlier.rows > vectors.size() || ::fstat(fd, &status) != 0 ||
      static_cast<uint64_t>(status.st_size) !=
          kHeaderBytes + earlier.rows * (row_bytes + kSummaryBytes)) {
    return false;
  }
  std::vector<uint8_t> bytes(std::max(row_bytes, kHeaderBytes));
  const size_t last = earlier.rows - 1;
  if (!readAt(fd, bytes.data(), kHeaderBytes, 0) ||
      std::memcmp(bytes.data(), header(vectors.dimension()).data(), kHeaderBytes) != 0 ||
      !readAt(fd, bytes.data(), row_bytes, static_cast<off_t>(kHeaderBytes + last * row_bytes)) ||
      std::memcmp(bytes.data(), vectors.row(last), row_bytes) != 0) {
    return false;
  }
  uint8_t stored[kSummaryBytes];
  uint8_t expected[kSummaryBytes];
  encodeSummary(summary_of(last), expected);
  return readAt(
             fd, stored, kSummaryBytes,
             static_cast<off_t>(kHeaderBytes + earlier.rows * row_bytes + last * kSummaryBytes)) &&
         std::memcmp(stored, expected, kSummaryBytes) == 0;
}

}  // namespace

Seal write(const std::string& path, const QuantizedVectors& vectors, size_t rows,
           const std::function<const KeyframeSummary&(size_t)>& summary_of, const Seal* earlier) {
  if (earlier != nullptr && earlier->rows <= rows) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd >= 0) {
      if (continues(fd, *earlier, vectors, summary_of)) {
        Seal seal = *earlier;
        const bool written = writeTail(fd, vectors, earlier->rows, rows, summary_of, &seal);
        const std::string reason = std::strerror(errno);
        ::close(fd);
        if (!written) throw writeError(path, reason);
        return seal;
      }
      ::close(fd);
    }
  }
  const std::string temporary = path + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw writeError(temporary, std::strerror(errno));
  const std::vector<uint8_t> head = header(vectors.dimension());
  Seal seal;
  seal.rows_checksum = crc32c(0, head.data(), head.size());
  const bool written = writeAt(fd, head.data(), head.size(), 0) &&
                       writeTail(fd, vectors, 0, rows, summary_of, &seal);
  const std::string reason = std::strerror(errno);
  ::close(fd);
  if (!written || std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw writeError(path, written ? std::strerror(errno) : reason);
  }
  return seal;
}

std::shared_ptr<const Mapped> Mapped::open(const std::string& path, const Seal& seal,
                                           int dimension) {
  if (seal.rows == 0 || dimension <= 0) return nullptr;
  // O_NONBLOCK: a FIFO put at this path is refused by the check below, not waited on.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return nullptr;
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(dimension);
  const size_t rows_end = kHeaderBytes + seal.rows * row_bytes;
  const size_t length = rows_end + seal.rows * kSummaryBytes;
  struct stat status;
  void* base = MAP_FAILED;
  if (::fstat(fd, &status) == 0 && S_ISREG(status.st_mode) &&
      static_cast<uint64_t>(status.st_size) == length) {
    base = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
  }
  ::close(fd);  // The mapping keeps the file.
  if (base == MAP_FAILED) return nullptr;
  std::shared_ptr<Mapped> mapped(new Mapped);
  mapped->base_ = static_cast<const uint8_t*>(base);
  mapped->length_ = length;
  mapped->header_bytes_ = kHeaderBytes;
  mapped->row_bytes_ = row_bytes;
  // Checked whole before a row is used: one pass front to back, which also brings the rows in.
  ::madvise(base, length, MADV_SEQUENTIAL);
  const uint8_t* bytes = mapped->base_;
  const bool valid = std::memcmp(bytes, header(dimension).data(), kHeaderBytes) == 0 &&
                     checksum(0, bytes, rows_end) == seal.rows_checksum &&
                     checksum(0, bytes + rows_end, length - rows_end) == seal.summaries_checksum;
  if (!valid) return nullptr;
  ::madvise(base, length, MADV_RANDOM);  // Search reads rows here and there.
  mapped->rows_ = seal.rows;
  return mapped;
}

Mapped::~Mapped() {
  if (base_ != nullptr) ::munmap(const_cast<uint8_t*>(base_), length_);
}

KeyframeSummary Mapped::summary(size_t index) const {
  const uint8_t* at = base_ + header_bytes_ + rows_ * row_bytes_ + index * kSummaryBytes;
  KeyframeSummary summary;
  summary.id = database_payload::decode<uint64_t>(at);
  summary.session = database_payload::decode<uint32_t>(at + 8);
  const uint64_t stamp_bits = database_payload::decode<uint64_t>(at + 12);
  std::memcpy(&summary.stamp, &stamp_bits, sizeof(stamp_bits));
  database_payload::decodeMotion(at + 20, kSummaryBytes - 20, &summary);
  return summary;
}

}  // namespace vector_file
}  // namespace landmark_loop_closure
