#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

namespace vector_file {
class Mapped;
}

/// The map on disk as an SQLite database (WAL journal): every keyframe is committed when it is
/// added, so a process killed at any moment loses none that add() returned for, and the file
/// always opens. Inspectable with the sqlite3 tool:
///   meta(key, value): format_version, descriptor_identity, global_dimension, and graph_identity,
///     graph_keyframes, graph_checksum (CRC-32C) of the search graph file PATH-graph, and
///     vectors_rows, vectors_checksum, vectors_last_id of the search rows file PATH-vectors
///     (vector_file.h), both written at a clean shutdown;
///   keyframes(id, session, stamp, motion, vector): what search keeps in RAM - `motion` the pose
///     and odometry path (9 little-endian doubles), `vector` the global descriptor as a
///     QuantizedVectors row;
///   records(id, record): the rest of the keyframe (keyframe_codec.h's encodeRecord), read for
///     the candidates of a query.
/// One process at a time: the file is locked while open. Not thread-safe; one owner.
class KeyframeStore {
 public:
  static constexpr int kFormatVersion = 2;

  /// Opens `path`, creating it when missing. Throws std::runtime_error naming the path and the
  /// reason when it is not a regular file (checked before opening, so a FIFO cannot block), cannot
  /// be written, is open in another process, was written by a newer version, or holds keyframes
  /// of another descriptor identity or global dimension.
  static std::unique_ptr<KeyframeStore> open(const std::string& path,
                                             const std::string& descriptor_identity,
                                             int global_dimension);
  /// What open() removed beside the map: temporary files of a save that was killed midway.
  const std::vector<std::string>& leftoversRemoved() const { return leftovers_removed_; }
  /// Opens an existing map whatever its descriptors (tools that copy or merge maps). Throws as
  /// open() does, and when `path` does not exist.
  static std::unique_ptr<KeyframeStore> openExisting(const std::string& path);
  /// True when `path` starts like the map file of the earlier format (versions 1-3), which
  /// `lcd_db convert` turns into a store once.
  static bool isOldMapFile(const std::string& path);
  /// Reads a map of store format 1 (a float32 `global` column and whole records in the earlier
  /// file's layout) for `lcd_db convert`: its descriptor identity and dimension, then every
  /// keyframe in id order. Throws std::runtime_error naming the path.
  static void readFormat1(const std::string& path, std::string* descriptor_identity,
                          int* global_dimension, const std::function<void(KeyframeRecord)>& visit);
  /// Renames the closed map `from` over `to`, first removing a write-ahead log left beside `to`
  /// by an earlier file there (SQLite would replay it into the new one). Throws
  /// std::runtime_error naming `to`.
  static void replaceFile(const std::string& from, const std::string& to);
  /// `keyframe` as a map gives it back: its record through the stored layout (landmark features
  /// in 8 bits, depths in float16 ...) and its global vector in 8 bits. What the evaluator
  /// compares, so its figures are those of a node with a map file.
  static KeyframeRecord asStored(const KeyframeRecord& keyframe);
  ~KeyframeStore();
  KeyframeStore(const KeyframeStore&) = delete;
  KeyframeStore& operator=(const KeyframeStore&) = delete;

  /// Writes and commits one keyframe. Throws std::runtime_error (disk full, id not greater than
  /// the last) with the store unchanged.
  void add(const KeyframeRecord& keyframe);
  /// Writes every keyframe of `database` in one transaction: all or none.
  void addAll(const KeyframeDatabase& database);
  /// The keyframe with this id, read from disk; nullopt when there is none. Throws
  /// std::runtime_error for a damaged record.
  std::optional<KeyframeRecord> get(uint64_t id) const;
  /// Every keyframe's summary and global vector row (QuantizedVectors) in id order, without
  /// reading the records: what search needs. Throws std::runtime_error for a damaged row.
  /// The rows saved at the last clean shutdown (vectorsPath()) are read from there when they are
  /// this map's.
  void forEachSummary(const std::function<void(const KeyframeSummary&, const uint8_t* vector_row,
                                               size_t row_bytes)>& visit) const;
  /// Fills an empty `database` with every keyframe's summary and row, as forEachSummary reads
  /// them, the saved rows mapped in place instead of copied (a second at 1 000 000 keyframes).
  void loadSearch(KeyframeDatabase* database) const;
  /// Every keyframe, whole, in id order.
  void forEach(const std::function<void(KeyframeRecord)>& visit) const;
  /// Writes a consistent copy of the map to `target` (SQLite's online backup) and renames it over
  /// whatever was there: the copy appears whole or not at all. The search graph is not copied.
  void copyTo(const std::string& target) const;
  /// Keeps `database`'s search graph and rows for the next open, in graphPath() and
  /// vectorsPath() with their checksums in the map: written at a clean shutdown, since they change
  /// with every keyframe; rows saved before are kept and the new ones appended. `database` is this
  /// map's search (loaded from it and grown with it); `graph_identity`:
  /// IndexOptions::graphIdentity(). Nothing without a graph. Throws std::runtime_error (disk full;
  /// search holds keyframes the map could not take).
  void saveGraph(const std::string& graph_identity, const KeyframeDatabase& database);
  /// The saved graph over `vectors` (the map's, in id order) when it was made with
  /// `graph_identity` and its file is the one saved; it may hold fewer keyframes than the map
  /// (after a crash). nullptr otherwise: the graph is then built again.
  std::unique_ptr<ApproximateIndex> loadGraph(const std::string& graph_identity,
                                              const QuantizedVectors* vectors, int neighbors) const;
  std::string graphPath() const;
  /// The search rows saved with the graph (PATH-vectors), read by forEachSummary.
  std::string vectorsPath() const;
  size_t size() const;
  const std::string& descriptorIdentity() const { return descriptor_identity_; }
  int globalDimension() const { return global_dimension_; }
  /// The sessions stored, ascending.
  std::vector<uint32_t> sessions() const;
  const std::string& path() const { return path_; }

 private:
  struct Connection;
  KeyframeStore(std::string path, std::unique_ptr<Connection> connection);
  void insert(const KeyframeRecord& keyframe);
  /// The saved rows when they are this map's; nullptr otherwise.
  std::shared_ptr<const vector_file::Mapped> savedRows() const;
  /// Hands the saved rows (when this map's) to `saved_rows`, then visits the keyframes after them.
  void readSummaries(
      const std::function<void(const std::shared_ptr<const vector_file::Mapped>&)>& saved_rows,
      const std::function<void(const KeyframeSummary&, const uint8_t*, size_t)>& visit) const;
  static std::unique_ptr<KeyframeStore> openChecked(const std::string& path,
                                                    const std::string* descriptor_identity,
                                                    int global_dimension);

  std::string path_;
  std::string descriptor_identity_;
  int global_dimension_ = 0;
  std::unique_ptr<Connection> connection_;
  std::vector<std::string> leftovers_removed_;
};

}  // namespace landmark_loop_closure
