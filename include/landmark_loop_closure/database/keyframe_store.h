#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

/// The map on disk as an SQLite database (WAL journal): every keyframe is committed when it is
/// added, so a process killed at any moment loses none that add() returned for, and the file
/// always opens. Inspectable with the sqlite3 tool:
///   meta(key, value): format_version, descriptor_identity, global_dimension
///   keyframes(id, session, stamp, global, record): `global` is the float32 global descriptor
///   (what search keeps in RAM), `record` the whole keyframe in the map file's layout.
/// One process at a time: the file is locked while open. Not thread-safe; one owner.
class KeyframeStore {
 public:
  static constexpr int kFormatVersion = 1;

  /// Opens `path`, creating it when missing. Throws std::runtime_error naming the path and the
  /// reason when it is not a regular file (checked before opening, so a FIFO cannot block), cannot
  /// be written, is open in another process, was written by a newer version, or holds keyframes
  /// of another descriptor identity or global dimension.
  static std::unique_ptr<KeyframeStore> open(const std::string& path,
                                             const std::string& descriptor_identity,
                                             int global_dimension);
  ~KeyframeStore();
  KeyframeStore(const KeyframeStore&) = delete;
  KeyframeStore& operator=(const KeyframeStore&) = delete;

  /// Writes and commits one keyframe. Throws std::runtime_error (disk full, id not greater than
  /// the last) with the store unchanged.
  void add(const KeyframeRecord& keyframe);
  /// The keyframe with this id, read from disk; nullopt when there is none. Throws
  /// std::runtime_error for a damaged record.
  std::optional<KeyframeRecord> get(uint64_t id) const;
  /// Every keyframe's id, session, stamp and global descriptor in id order, without reading the
  /// rest: what a search index needs.
  void forEachGlobal(const std::function<void(uint64_t id, uint32_t session, double stamp,
                                              std::vector<float> global)>& visit) const;
  size_t size() const;
  /// The sessions stored, ascending.
  std::vector<uint32_t> sessions() const;
  const std::string& path() const { return path_; }

 private:
  struct Connection;
  KeyframeStore(std::string path, std::unique_ptr<Connection> connection);

  std::string path_;
  std::unique_ptr<Connection> connection_;
};

}  // namespace landmark_loop_closure
