#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/map_copy.h"

struct sqlite3_stmt;

namespace landmark_loop_closure {

namespace vector_file {
class Writer;
}

/// The map on disk: an SQLite database (WAL journal) and its search rows file PATH-vectors beside
/// it (vector_file.h; the two are one map: copy, move and delete them together). Every keyframe
/// is committed when it is added, its search row written just before, so a process killed at
/// any moment loses none that add() returned for, and the map always opens. A clean shutdown
/// also keeps, for a fast next open, the search graph (PATH-graph) and the searched keyframes'
/// summaries in one piece (PATH-summaries, 92 bytes each): both are used only while the map says
/// they are its own, and opening without them reads the rows file instead. The database is
/// inspectable with the sqlite3 tool:
///   meta(key, value): format_version, descriptor_identity, global_dimension, map_id;
///     graph_identity,
///     graph_keyframes, graph_checksum (CRC-32C) of PATH-graph; summaries_keyframes,
///     summaries_checksum of PATH-summaries; and the rows file's seal vectors_rows,
///     vectors_checksum, vectors_last_id (its first vectors_rows entries and their CRC-32C), all
///     written at a clean shutdown;
///   keyframes(id, session, stamp, motion, search_row, row_checksum): the summary - `motion` the
///     pose and odometry path (9 little-endian doubles) - and which entry of PATH-vectors holds
///     the keyframe's global descriptor (a QuantizedVectors row), with that entry's CRC-32C;
///   records(id, record): the rest of the keyframe (keyframe_codec.h's encodeRecord), read for
///     the candidates of a query;
///   keyframe_stamps(id, stamp_ns): the image's stamp exactly, in integer nanoseconds (the
///     `stamp` column is REAL seconds, about 0.2 us apart); a map written before it gains the
///     table with its next keyframe, and its earlier keyframes read their seconds, rounded.
/// One process at a time: the file is locked while open. Not thread-safe; one owner.
///
/// Opening checks each row written since the last clean shutdown against its keyframe, and of
/// the sealed rows only that the file holds them and that the last is the right keyframe's. The
/// rest of an existing map's integrity - the sealed rows' checksum (the whole rows file: 4.4 GB at
/// 1 000 000 keyframes) and SQLite's quick_check of every page of the database file - is checked
/// by checkIntegrity(), which openExisting() runs, or by startIntegrityCheck() while search
/// already runs on the map. Until it passes nothing is written to the map: keyframes added
/// meanwhile are held in memory (get() finds them) and committed once it passes; a map found
/// damaged is never written to again by this store.
class KeyframeStore {
  friend class MapCopy;

 public:
  static constexpr int kFormatVersion = 3;

  /// Where the integrity check of an opened map stands.
  enum class MapCheck {
    kPassed,   ///< Checked, or a map created by this open.
    kPending,  ///< Not started.
    kRunning,  ///< On its thread.
    kFailed,   ///< Damaged or another map's rows: integrityProblem() says so.
    /// Could not be checked for the disk's sake (no room to write the log into the file, an I/O
    /// error reading it): not damage. Nothing is written meanwhile; add() and
    /// reserveIdsThrough() try the check again (at most once a second) and refuse until it runs.
    kDeferred,
  };

  /// Opens `path`, creating it when missing. Throws std::runtime_error naming the path and the
  /// reason when it is not a regular file (checked before opening, so a FIFO cannot block), is
  /// empty or not a map of this package (another program's file is never written to), cannot be
  /// written, is open in another process, was written by a newer version, or holds keyframes of
  /// another descriptor identity or global dimension.
  static std::unique_ptr<KeyframeStore> open(const std::string& path,
                                             const std::string& descriptor_identity,
                                             int global_dimension);
  /// What open() removed beside the map: temporary files of a save that was killed midway.
  const std::vector<std::string>& leftoversRemoved() const { return leftovers_removed_; }
  /// What opening repaired, one line each: keyframes a power cut left without their search row
  /// (the last ones) are removed from the map.
  const std::vector<std::string>& repairs() const { return repairs_; }
  /// Opens an existing map whatever its descriptors (tools that copy or merge maps), its
  /// integrity checked. Throws as open() and checkIntegrity() do, and when `path` does not exist.
  static std::unique_ptr<KeyframeStore> openExisting(const std::string& path);
  /// True when `path` starts like the map file of the earlier format (versions 1-3), which
  /// `lcd_db convert` turns into a store once.
  static bool isOldMapFile(const std::string& path);
  /// Reads a map of store format 1 (whole records in the earlier file's layout) or 2 (the 8-bit
  /// global row in the database) for `lcd_db convert`: its descriptor identity and dimension,
  /// then every keyframe in id order. Throws std::runtime_error naming the path.
  static void readEarlierFormat(const std::string& path, std::string* descriptor_identity,
                                int* global_dimension,
                                const std::function<void(KeyframeRecord)>& visit);
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

  /// Checks the map's integrity now, unless already done. Throws std::runtime_error naming the
  /// file and what is wrong when it is damaged (or its rows are another map's).
  void checkIntegrity();
  /// Checks it on a thread of its own (reading the files, little CPU); the destructor stops it.
  void startIntegrityCheck();
  MapCheck integrityCheck() const;
  /// Waits for a check started by startIntegrityCheck(); its outcome.
  MapCheck awaitIntegrityCheck();
  /// Why the check failed; "" unless kFailed.
  std::string integrityProblem() const;
  /// Why the check could not run; "" unless kDeferred.
  std::string integrityDeferredBy() const;
  /// Keyframes added while the check runs, not yet committed.
  size_t heldKeyframes() const { return held_.size(); }
  /// Commits the held keyframes once the check has passed (add() does too, with the next one).
  /// Throws std::runtime_error when the disk refuses them; they stay held.
  void commitHeldIfChecked() {
    if (integrityCheck() == MapCheck::kPassed) commitHeld();
  }
  /// The id of the last keyframe committed to the file, if any.
  std::optional<uint64_t> lastCommittedId() const;

  /// Writes and commits one keyframe (with those held before it); while the integrity check runs
  /// it is held instead, and a pending check is run first. Throws std::runtime_error (disk full,
  /// id not greater than the last, the map found damaged) with the store unchanged.
  void add(const KeyframeRecord& keyframe);
  /// Keyframe ids up to `id` have been published (a keyframe held back before it is stored, as
  /// while the standardisation warms up): the map keeps the mark, so a run on it after a crash
  /// does not give them again. Written now, or once the integrity check passes; a damaged map is
  /// not written. Throws std::runtime_error when the disk refuses it (or the check is deferred).
  void reserveIdsThrough(uint64_t id);
  /// The highest id reserved so far (this run's or the map's), if any.
  std::optional<uint64_t> idsReservedThrough() const;
  /// A reservation waits for the integrity check to be written (commitHeldIfChecked writes it).
  bool reservationUnsaved() const { return reservation_unsaved_; }
  /// The highest id whose reservation the file holds, if any.
  std::optional<uint64_t> idsReservedInFile() const;
  /// Session `session` has been used by a run that stores nothing (localisation): kept with the
  /// ids' reservation, so that the next run on the map takes the session after it.
  void reserveSession(uint32_t session);
  /// The highest session reserved so far, if any.
  std::optional<uint32_t> sessionsReservedThrough() const { return sessions_reserved_through_; }
  /// Writes every keyframe of `database` in one transaction: all or none.
  void addAll(const KeyframeDatabase& database);
  /// The keyframe with this id, read from disk; nullopt when there is none. Throws
  /// std::runtime_error for a damaged record.
  std::optional<KeyframeRecord> get(uint64_t id) const;
  /// Every keyframe's summary and global vector row (QuantizedVectors) in id order, as the
  /// search rows file holds them, without reading the records: what search needs.
  void forEachSummary(const std::function<void(const KeyframeSummary&, const uint8_t* vector_row,
                                               size_t row_bytes)>& visit) const;
  /// Fills an empty `database` with every keyframe's summary and row, the rows file mapped and
  /// its rows used in place instead of copied; the summaries read from PATH-summaries when it is
  /// the map's, so the rows are not read at all here.
  void loadSearch(KeyframeDatabase* database) const { loadSearch(database, size()); }
  /// The same for the map's first `keyframes` only (a memory budget).
  void loadSearch(KeyframeDatabase* database, size_t keyframes) const;
  /// Bytes from one row to the next where loadSearch() leaves them (the rows file's entries).
  size_t rowStride() const;
  /// The last keyframe's summary, read from the rows file; nullopt when the map is empty.
  std::optional<KeyframeSummary> lastSummary() const;
  /// Every keyframe, whole, in id order.
  void forEach(const std::function<void(KeyframeRecord)>& visit) const;
  /// Writes a consistent copy of the map and its rows file to `target` (SQLite's online backup)
  /// and renames them over whatever was there. The search graph is not copied. Waits for the
  /// integrity check and refuses a damaged map.
  void copyTo(const std::string& target);
  /// copyTo() in steps (MapCopy): nothing is written before the first step.
  std::unique_ptr<MapCopy> startCopy(const std::string& target);
  /// At a clean shutdown: flushes the rows file and seals it (its checksum so far in the map, so
  /// the next open checks it in one pass), and keeps `database`'s search graph and summaries for
  /// the next open in graphPath() and summariesPath() with their checksums in the map. `database`
  /// is this map's search (loaded from it and grown with it); `graph_identity`:
  /// IndexOptions::graphIdentity(); it may hold the map's first keyframes only (the rest written
  /// past the memory budget). Throws std::runtime_error (disk full; search holds keyframes the map
  /// could not take: no graph is saved then).
  void saveGraph(const std::string& graph_identity, const KeyframeDatabase& database);
  /// The saved graph over `vectors` (the map's, in id order) when it was made with
  /// `graph_identity` and its file is the one saved; it may hold fewer keyframes than the map
  /// (after a crash, or past the memory budget). nullptr otherwise: the graph is then built again.
  std::unique_ptr<ApproximateIndex> loadGraph(const std::string& graph_identity,
                                              const QuantizedVectors* vectors, int neighbors) const;
  /// Keyframes the graph saved with `graph_identity` covers, as the map says; 0 without one or
  /// when its file is gone.
  size_t savedGraphKeyframes(const std::string& graph_identity) const;
  std::string graphPath() const;
  std::string summariesPath() const;
  /// The search rows file (PATH-vectors).
  std::string vectorsPath() const;
  /// Keyframes of the map, held ones included.
  size_t size() const;
  const std::string& descriptorIdentity() const { return descriptor_identity_; }
  /// This map's identity: a random number drawn when the map was created (a copy by copyTo()
  /// draws its own), so that (map id, keyframe id) names one keyframe for ever while keyframe ids
  /// repeat between maps. A map from before map ids draws one at open and keeps it with its next
  /// commit (a map never committed to again keeps none: it is never written to).
  uint64_t mapId() const { return map_id_; }
  /// A new map identity: 64 random bits, never 0.
  static uint64_t drawMapId();
  int globalDimension() const { return global_dimension_; }
  /// The sessions stored, ascending.
  std::vector<uint32_t> sessions() const;
  const std::string& path() const { return path_; }

 private:
  struct Connection;
  KeyframeStore(std::string path, std::unique_ptr<Connection> connection);
  /// Writes one keyframe's search row and database rows (inside a transaction); returns the
  /// row entry's CRC-32C.
  uint32_t insert(const KeyframeRecord& keyframe);
  /// A keyframe from a row of (session, stamp, motion, search_row, row_checksum, record) at
  /// `first_column`, its global row read from the rows file.
  KeyframeRecord readRow(sqlite3_stmt* row, int first_column, uint64_t id) const;
  /// Prepares the connection's select by id, with the exact stamps when the map has them.
  static void prepareSelect(Connection* c);
  /// Creates the exact stamps' table in a map of an earlier version (once, before a write).
  void addStampTable();
  /// Opens the rows file and checks it against the map: the later entries against their
  /// keyframes' checksums here, the sealed ones by the integrity check (set up here). Throws
  /// std::runtime_error when it is missing or damaged; removes the last keyframes when a power cut
  /// lost their rows (repairs()).
  void openRows();
  /// Which entry of the rows file keyframe `id`'s is; nullopt when the map lacks it.
  std::optional<uint64_t> searchRowOf(uint64_t id) const;
  /// Writes the first `count` summaries of `database` to summariesPath(); their checksum, or
  /// nullopt and why in `error`.
  std::optional<uint32_t> saveSummaries(const KeyframeDatabase& database, size_t count,
                                        std::string* error) const;
  /// The summaries saved at the last clean shutdown when they are this map's (92 bytes each, the
  /// rows file's encoding); empty otherwise.
  std::vector<uint8_t> savedSummaries() const;
  /// The summary in the rows file's entry `position`. Throws std::runtime_error naming the map.
  KeyframeSummary entrySummary(size_t position) const;
  static std::unique_ptr<KeyframeStore> openChecked(const std::string& path,
                                                    const std::string* descriptor_identity,
                                                    int global_dimension);

  std::string path_;
  std::string descriptor_identity_;
  int global_dimension_ = 0;
  uint64_t map_id_ = 0;
  bool map_id_unsaved_ = false;               ///< Drawn at this open, written with the next commit.
  std::optional<uint64_t> reserved_through_;  ///< reserveIdsThrough(), the map's mark at open.
  std::optional<uint64_t> reserved_in_file_;  ///< What the file holds of it.
  std::optional<uint32_t> sessions_reserved_through_;  ///< reserveSession(), the map's at open.
  bool reservation_unsaved_ = false;  ///< Not written yet (the check had not passed).
  void saveReservation();
  /// A deferred check tried again (at most once a second); false while it stays deferred.
  bool retryDeferredCheck();
  std::unique_ptr<Connection> connection_;
  std::unique_ptr<vector_file::Writer> rows_;
  /// Commits the held keyframes in one transaction (the check passed, or was given up at close).
  void commitHeld();
  /// Writes keyframes in one transaction: all or none. Throws std::runtime_error.
  void insertInOneTransaction(size_t count,
                              const std::function<const KeyframeRecord*(size_t)>& keyframe);
  /// Marks a pending check running and checkpoints the log into the file it reads; when the
  /// checkpoint fails (a full disk) the check is deferred instead. `background`: on a thread.
  void beginIntegrityCheck(bool background);
  /// Stops a running check and commits what it held: the map was not found damaged.
  void settleBeforeClose();
  struct IntegrityCheck;
  std::unique_ptr<IntegrityCheck> check_;  ///< Null for a map this open created.
  std::vector<KeyframeRecord> held_;       ///< Added while the check runs, in id order.
  uint32_t entries_checksum_ = 0;  ///< CRC-32C of the rows file's header and entries so far.
  std::vector<std::string> leftovers_removed_;
  std::vector<std::string> repairs_;
};

}  // namespace landmark_loop_closure
