#pragma once

// Every file the package writes goes through here: written to a temporary file beside its name,
// each write, the fsync and the close checked, then renamed over the name and the folder synced.
// A write that fails (a full disk, an I/O error while the tail is flushed at close) removes the
// temporary, leaves the earlier file as it was and says why.

#include <cstddef>
#include <optional>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// A file being written; commit() puts it under its name. Destroyed uncommitted, it leaves no
/// trace (the temporary is removed) and the earlier file untouched.
class DurableFile {
 public:
  /// Opens the temporary PATH.tmp for writing; a failure is kept for commit() to say.
  explicit DurableFile(std::string path);
  ~DurableFile();
  DurableFile(const DurableFile&) = delete;
  DurableFile& operator=(const DurableFile&) = delete;

  /// Appends `size` bytes; false once anything failed (the first failure is kept).
  bool write(const void* data, size_t size);
  bool write(const std::string& text) { return write(text.data(), text.size()); }
  /// Syncs and closes the temporary, renames it over the path and syncs the folder. Returns ""
  /// or why not (the earlier file is then as it was).
  std::string commit();
  const std::string& path() const { return path_; }

 private:
  void failWith(const std::string& what, int error_number);
  std::string path_;
  std::string temporary_;
  int fd_ = -1;
  std::string error_;
  bool committed_ = false;
};

/// Writes `size` bytes as the whole file `path` through DurableFile. Returns "" or why not.
std::string writeFileDurably(const std::string& path, const void* data, size_t size);
inline std::string writeFileDurably(const std::string& path, const std::string& text) {
  return writeFileDurably(path, text.data(), text.size());
}

/// For a temporary another library wrote (the search graph's hnswlib, SQLite's copy): syncs it,
/// renames it over `path` and syncs the folder. Returns "" or why not (the temporary is then
/// removed, the earlier file left as it was).
std::string syncAndRename(const std::string& temporary, const std::string& path);

/// Syncs the folder holding `path`, so that a rename in it survives a power cut. Returns "" or
/// why not.
std::string syncFolderOf(const std::string& path);

/// A text file (a report, a table) composed in memory and written whole by commit(), which
/// throws std::runtime_error naming the file when it cannot be written. Never committed: nothing
/// is written.
class DurableText : public std::ostringstream {
 public:
  explicit DurableText(std::string path) : path_(std::move(path)) {}
  void commit();

 private:
  std::string path_;
};

/// An image encoded by its path's extension (cv::imencode) and written through DurableFile.
/// Throws std::runtime_error naming the file when it cannot be encoded or written.
void writeImageDurably(const std::string& path, const cv::Mat& image);

/// Tests: faults the writes above meet, process-wide, until cleared (a disk that fills after a
/// number of bytes, a close that fails as an NFS or a full quota does). No mount needed.
struct WriteFaults {
  std::optional<size_t> bytes_until_full;  ///< Writes past this many bytes fail with ENOSPC.
  bool fail_on_close = false;              ///< Closing a written file fails with EIO.
};
void setWriteFaults(const WriteFaults& faults);
void clearWriteFaults();

}  // namespace landmark_loop_closure
