#include "database/vector_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "common/crc32c.h"
#include "database/database_payload.h"
#include "database/keyframe_codec.h"

namespace landmark_loop_closure {
namespace vector_file {

namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'V', 'E', 'C', '3', '\n'};
constexpr size_t kPieceBytes = 8 << 20;
// Files this large are checked in two streams.
constexpr size_t kTwoStreamsFrom = size_t{256} << 20;

std::runtime_error fileError(const std::string& path, const std::string& what) {
  return std::runtime_error("search rows " + path + ": " + what);
}

size_t rowBytes(int dimension) { return sizeof(float) + static_cast<size_t>(dimension); }

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

// The file's first bytes for rows of `dimension` values.
std::vector<uint8_t> header(int dimension) {
  std::vector<uint8_t> bytes(kHeaderBytes);
  std::memcpy(bytes.data(), kMagic, 8);
  database_payload::encode(static_cast<uint32_t>(dimension), bytes.data() + 8);
  database_payload::encode(static_cast<uint32_t>(kSummaryBytes), bytes.data() + 12);
  return bytes;
}

}  // namespace

void encodeSummary(const KeyframeSummary& summary, uint8_t* out) {
  database_payload::encode(summary.id, out);
  database_payload::encode(summary.session, out + 8);
  uint64_t stamp_bits;
  std::memcpy(&stamp_bits, &summary.stamp, sizeof(stamp_bits));
  database_payload::encode(stamp_bits, out + 12);
  const std::vector<uint8_t> motion = database_payload::encodeMotion(summary);
  std::memcpy(out + 20, motion.data(), motion.size());
}

KeyframeSummary decodeSummary(const uint8_t* at) {
  KeyframeSummary summary;
  summary.id = database_payload::decode<uint64_t>(at);
  summary.session = database_payload::decode<uint32_t>(at + 8);
  const uint64_t stamp_bits = database_payload::decode<uint64_t>(at + 12);
  std::memcpy(&summary.stamp, &stamp_bits, sizeof(stamp_bits));
  database_payload::decodeMotion(at + 20, kSummaryBytes - 20, &summary);
  return summary;
}

size_t entryBytes(int dimension) { return rowBytes(dimension) + kSummaryBytes; }

std::vector<uint8_t> entry(const std::vector<uint8_t>& row, const KeyframeSummary& summary) {
  std::vector<uint8_t> bytes(row.size() + kSummaryBytes);
  std::memcpy(bytes.data(), row.data(), row.size());
  encodeSummary(summary, bytes.data() + row.size());
  return bytes;
}

Writer::Writer(const std::string& path, int dimension)
    : path_(path), entry_bytes_(entryBytes(dimension)) {
  // O_NONBLOCK: a FIFO put at this path is refused below, not waited on.
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_NONBLOCK | O_CLOEXEC, 0644);
  if (fd_ < 0) throw fileError(path, std::string("cannot be opened: ") + std::strerror(errno));
  struct stat status;
  std::string problem;
  const std::vector<uint8_t> expected = header(dimension);
  if (::fstat(fd_, &status) != 0 || !S_ISREG(status.st_mode)) {
    problem = "is not a regular file";
  } else if (status.st_size == 0) {
    if (!writeAt(fd_, expected.data(), expected.size(), 0)) {
      problem = std::string("cannot be written: ") + std::strerror(errno);
    }
  } else {
    std::vector<uint8_t> stored(kHeaderBytes);
    if (!readAt(fd_, stored.data(), stored.size(), 0) || stored != expected) {
      problem = "is not this map's (another header)";
    }
  }
  if (!problem.empty()) {
    ::close(fd_);
    throw fileError(path, problem);
  }
}

Writer::~Writer() {
  if (fd_ >= 0) ::close(fd_);
}

void Writer::write(size_t position, const uint8_t* entry) {
  if (!writeAt(fd_, entry, entry_bytes_,
               static_cast<off_t>(kHeaderBytes + position * entry_bytes_))) {
    throw fileError(path_, std::string("cannot be written: ") + std::strerror(errno));
  }
}

std::vector<uint8_t> Writer::read(size_t position) const {
  std::vector<uint8_t> bytes(entry_bytes_);
  if (!readAt(fd_, bytes.data(), bytes.size(),
              static_cast<off_t>(kHeaderBytes + position * entry_bytes_))) {
    return {};
  }
  return bytes;
}

uint64_t Writer::entriesOnDisk() const {
  struct stat status;
  if (::fstat(fd_, &status) != 0 || static_cast<size_t>(status.st_size) < kHeaderBytes) return 0;
  return (static_cast<size_t>(status.st_size) - kHeaderBytes) / entry_bytes_;
}

void Writer::sync() {
  if (::fdatasync(fd_) != 0) {
    throw fileError(path_, std::string("cannot be flushed: ") + std::strerror(errno));
  }
}

void Writer::truncate(uint64_t entries) {
  if (::ftruncate(fd_, static_cast<off_t>(kHeaderBytes + entries * entry_bytes_)) != 0) {
    throw fileError(path_, std::string("cannot be cut: ") + std::strerror(errno));
  }
}

std::shared_ptr<const Mapped> Mapped::open(const std::string& path, int dimension,
                                           uint64_t entries) {
  if (dimension <= 0) return nullptr;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return nullptr;
  const size_t entry_bytes = vector_file::entryBytes(dimension);
  const size_t length = kHeaderBytes + entries * entry_bytes;
  struct stat status;
  void* base = MAP_FAILED;
  if (::fstat(fd, &status) == 0 && S_ISREG(status.st_mode) &&
      static_cast<uint64_t>(status.st_size) >= length) {
    base = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
  }
  ::close(fd);  // The mapping keeps the file.
  if (base == MAP_FAILED) return nullptr;
  std::shared_ptr<Mapped> mapped(new Mapped);
  mapped->base_ = static_cast<const uint8_t*>(base);
  mapped->length_ = length;
  mapped->entry_bytes_ = entry_bytes;
  mapped->row_bytes_ = rowBytes(dimension);
  mapped->entries_ = entries;
  if (std::memcmp(mapped->base_, header(dimension).data(), kHeaderBytes) != 0) return nullptr;
  ::madvise(base, length, MADV_SEQUENTIAL);  // Checked front to back before a row is used.
  return mapped;
}

Mapped::~Mapped() {
  if (base_ != nullptr) ::munmap(const_cast<uint8_t*>(base_), length_);
}

KeyframeSummary Mapped::summary(size_t index) const {
  return decodeSummary(entry(index) + row_bytes_);
}

uint32_t Mapped::checksum(uint64_t count) const { return *checksumUnless(count, nullptr); }

std::optional<uint32_t> Mapped::checksum(uint64_t count, const std::atomic<bool>& stop) const {
  return checksumUnless(count, &stop);
}

std::optional<uint32_t> Mapped::checksumUnless(uint64_t count,
                                               const std::atomic<bool>* stop) const {
  const size_t size = kHeaderBytes + std::min(count, entries_) * entry_bytes_;
  const auto checksumOf = [this, stop](size_t from, size_t to) {
    uint32_t crc = 0;
    for (size_t done = from; done < to; done += kPieceBytes) {
      if (stop != nullptr && stop->load(std::memory_order_relaxed)) break;
      crc = crc32c(crc, base_ + done, std::min(kPieceBytes, to - done));
    }
    return crc;
  };
  const auto stopped = [stop] { return stop != nullptr && stop->load(); };
  const auto oneStream = [&]() -> std::optional<uint32_t> {
    const uint32_t crc = checksumOf(0, size);
    if (stopped()) return std::nullopt;
    return crc;
  };
  if (size < kTwoStreamsFrom) return oneStream();
  // From a cold disk one sequential stream reads ~1.1 GB/s here and two ~2 GB/s: the second half
  // is read by a helper thread (waiting on the disk, hardly any CPU) and the CRCs combined.
  const size_t half = size / 2;
  uint32_t second = 0;
  std::thread helper;
  try {
    helper = std::thread([&] { second = checksumOf(half, size); });
  } catch (const std::system_error&) {
    return oneStream();  // No thread to be had.
  }
  const uint32_t first = checksumOf(0, half);
  helper.join();
  if (stopped()) return std::nullopt;
  return crc32cCombine(first, second, size - half);
}

void Mapped::readAtRandom() const { ::madvise(const_cast<uint8_t*>(base_), length_, MADV_RANDOM); }

}  // namespace vector_file
}  // namespace landmark_loop_closure
