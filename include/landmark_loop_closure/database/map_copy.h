#pragma once

// A copy of an open map written in steps, so that whoever owns the map (the detector's worker)
// is held for milliseconds at a time instead of for the whole copy.

#include <cstddef>
#include <cstdint>
#include <string>

struct sqlite3;
struct sqlite3_backup;

namespace landmark_loop_closure {

class KeyframeStore;

/// Made by KeyframeStore::startCopy(). step() copies the database page by page from the store's
/// own connection (SQLite's online backup: keyframes committed between steps are copied too);
/// once it is whole, finish() copies the search rows its keyframes use and renames the copy to
/// its target, on any thread. Destroyed unfinished, it removes what it wrote. The store must
/// outlive the steps (not finish()).
class MapCopy {
 public:
  ~MapCopy();
  MapCopy(const MapCopy&) = delete;
  MapCopy& operator=(const MapCopy&) = delete;

  /// The store's thread: copies up to `pages` more pages (-1: all). True once the database part
  /// is whole (then the copy no longer needs the store); false while more remains, or while the
  /// store's integrity check still runs (nothing copied yet). Throws std::runtime_error naming
  /// the target (a damaged map, a full disk).
  bool step(int pages);
  /// Any thread, after step() returned true: the rows file, then both files renamed over the
  /// target. Throws std::runtime_error naming the target; what was written is removed.
  void finish();
  const std::string& target() const { return target_; }
  /// Keyframes in the copy (known once step() returned true).
  size_t keyframes() const { return keyframes_; }

 private:
  friend class KeyframeStore;
  MapCopy(KeyframeStore* source, std::string target);
  /// Closes what is open and, unless finished, removes what was written.
  void discard();
  [[noreturn]] void fail(const std::string& what);

  KeyframeStore* source_;  ///< Null once the database part is whole.
  std::string target_;
  std::string partial_;  ///< Where the copy is written before it is renamed to target_.
  sqlite3* copy_ = nullptr;
  sqlite3_backup* backup_ = nullptr;
  int rows_fd_ = -1;         ///< The source's rows file, opened when the database part is whole.
  uint64_t rows_bytes_ = 0;  ///< Of it, what the copy's keyframes use.
  size_t keyframes_ = 0;
  bool finished_ = false;
};

}  // namespace landmark_loop_closure
