#include "landmark_loop_closure/common/durable_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

namespace {

Mutex faults_mutex;
WriteFaults faults GUARDED_BY(faults_mutex);

// write(2) through the faults a test set: a full disk past its bytes.
ssize_t writeSome(int fd, const char* data, size_t size) {
  {
    MutexLock lock(faults_mutex);
    if (faults.bytes_until_full) {
      if (*faults.bytes_until_full == 0) {
        errno = ENOSPC;
        return -1;
      }
      size = std::min(size, *faults.bytes_until_full);
      *faults.bytes_until_full -= size;
    }
  }
  return ::write(fd, data, size);
}

// close(2), or EIO when a test says so (the file is closed all the same).
int closeFile(int fd) {
  const int status = ::close(fd);
  MutexLock lock(faults_mutex);
  if (status == 0 && faults.fail_on_close) {
    errno = EIO;
    return -1;
  }
  return status;
}

std::string systemError(const std::string& what, const std::string& path, int error_number) {
  return "cannot " + what + " " + path + ": " + std::strerror(error_number);
}

}  // namespace

void setWriteFaults(const WriteFaults& set) {
  MutexLock lock(faults_mutex);
  faults = set;
}

void clearWriteFaults() { setWriteFaults(WriteFaults{}); }

DurableFile::DurableFile(std::string path) : path_(std::move(path)), temporary_(path_ + ".tmp") {
  fd_ = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) error_ = systemError("create", temporary_, errno);
}

DurableFile::~DurableFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_) ::unlink(temporary_.c_str());
}

void DurableFile::failWith(const std::string& what, int error_number) {
  if (error_.empty()) error_ = systemError(what, temporary_, error_number);
}

bool DurableFile::write(const void* data, size_t size) {
  if (!error_.empty()) return false;
  const char* next = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t written = writeSome(fd_, next, size);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) {
      failWith("write", written < 0 ? errno : ENOSPC);
      return false;
    }
    next += written;
    size -= static_cast<size_t>(written);
  }
  return true;
}

std::string DurableFile::commit() {
  if (error_.empty() && ::fsync(fd_) != 0) failWith("sync", errno);
  if (fd_ >= 0) {
    // A file system may report a failed write of the tail only here (NFS, a quota).
    const int closed = closeFile(fd_);
    fd_ = -1;
    if (closed != 0) failWith("close", errno);
  }
  if (!error_.empty()) {
    ::unlink(temporary_.c_str());
    return error_ + "; " + path_ + " is left as it was";
  }
  if (::rename(temporary_.c_str(), path_.c_str()) != 0) {
    const int error_number = errno;
    ::unlink(temporary_.c_str());
    return systemError("rename " + temporary_ + " to", path_, error_number);
  }
  committed_ = true;
  return syncFolderOf(path_);
}

std::string writeFileDurably(const std::string& path, const void* data, size_t size) {
  DurableFile file(path);
  file.write(data, size);
  return file.commit();
}

std::string syncAndRename(const std::string& temporary, const std::string& path) {
  const int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
  std::string error;
  if (fd < 0) {
    error = systemError("open", temporary, errno);
  } else {
    if (::fsync(fd) != 0) error = systemError("sync", temporary, errno);
    if (closeFile(fd) != 0 && error.empty()) error = systemError("close", temporary, errno);
  }
  if (error.empty() && ::rename(temporary.c_str(), path.c_str()) != 0) {
    error = systemError("rename " + temporary + " to", path, errno);
  }
  if (!error.empty()) {
    ::unlink(temporary.c_str());
    return error + "; " + path + " is left as it was";
  }
  return syncFolderOf(path);
}

std::string syncFolderOf(const std::string& path) {
  std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (folder.empty()) folder = ".";
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return systemError("open the folder", folder.string(), errno);
  const int synced = ::fsync(fd);
  const int error_number = errno;
  ::close(fd);
  // Some file systems cannot sync a folder (EINVAL): the rename is as safe as they make it.
  if (synced != 0 && error_number != EINVAL) {
    return systemError("sync the folder", folder.string(), error_number);
  }
  return "";
}

void DurableText::commit() {
  if (const std::string failed = writeFileDurably(path_, str()); !failed.empty()) {
    throw std::runtime_error(failed);
  }
}

void writeImageDurably(const std::string& path, const cv::Mat& image) {
  std::vector<uint8_t> encoded;
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension.empty() || !cv::imencode(extension, image, encoded)) {
    throw std::runtime_error("cannot encode " + path + " as " + extension);
  }
  if (const std::string failed = writeFileDurably(path, encoded.data(), encoded.size());
      !failed.empty()) {
    throw std::runtime_error(failed);
  }
}

}  // namespace landmark_loop_closure
