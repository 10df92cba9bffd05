#pragma once

// The SQLite connection behind a KeyframeStore, shared by its source files
// (keyframe_store_open.cpp: opening and closing; keyframe_store.cpp: writing and reading keyframes;
// keyframe_store_search.cpp: what search reads at open and the files saved beside the map).
// Private to the core library.

#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "database/vector_file.h"
#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {

inline std::runtime_error storeError(const std::string& path, const std::string& reason) {
  return std::runtime_error("map " + path + ": " + reason);
}

/// Refuses what is not a regular file before SQLite opens it (keyframe_store_open.cpp).
void checkMapPath(const std::string& path);

// The exact stamps beside `keyframes` (REAL seconds there, kept for maps read by earlier
// versions): a table of its own, so an earlier version still opens a map that has it.
inline constexpr const char* kCreateStampsTable =
    "CREATE TABLE IF NOT EXISTS keyframe_stamps (id INTEGER PRIMARY KEY, stamp_ns INTEGER NOT "
    "NULL)";

struct KeyframeStore::Connection {
  sqlite3* db = nullptr;
  sqlite3_stmt* insert = nullptr;
  sqlite3_stmt* insert_record = nullptr;
  sqlite3_stmt* select = nullptr;
  sqlite3_stmt* insert_stamp = nullptr;
  /// The map has its keyframe_stamps table (exact stamps; maps written before lack it until
  /// their next keyframe).
  bool has_stamps = false;
  std::string path;
  size_t count = 0;
  std::optional<uint64_t> last_id;

  ~Connection() {
    sqlite3_finalize(insert);
    sqlite3_finalize(insert_record);
    sqlite3_finalize(select);
    sqlite3_finalize(insert_stamp);
    if (db != nullptr) sqlite3_close(db);  // The last connection checkpoints the WAL.
  }

  [[noreturn]] void fail(const std::string& what) const {
    const int code = db != nullptr ? sqlite3_errcode(db) : SQLITE_ERROR;
    if (code == SQLITE_BUSY || code == SQLITE_LOCKED) {
      throw storeError(path, "is open in another process (one node per map)");
    }
    if (code == SQLITE_FULL) throw storeError(path, what + ": the disk is full");
    std::string reason = db != nullptr ? sqlite3_errmsg(db) : "no connection";
    // SQLite's "disk I/O error" says little: the system's reason (no space, file too large,
    // read-only file system...) says what to do.
    const int system_error = db != nullptr ? sqlite3_system_errno(db) : 0;
    if (system_error != 0) reason += std::string(" (") + std::strerror(system_error) + ")";
    throw storeError(path, what + ": " + reason);
  }

  void execute(const char* sql, const std::string& what) {
    if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) fail(what);
  }

  sqlite3_stmt* prepare(const char* sql) {
    sqlite3_stmt* statement = nullptr;
    if (sqlite3_prepare_v2(db, sql, -1, &statement, nullptr) != SQLITE_OK) fail("cannot read it");
    return statement;
  }

  std::optional<std::string> meta(const std::string& key) {
    sqlite3_stmt* statement = prepare("SELECT value FROM meta WHERE key = ?");
    sqlite3_bind_text(statement, 1, key.c_str(), -1, SQLITE_TRANSIENT);
    std::optional<std::string> value;
    if (sqlite3_step(statement) == SQLITE_ROW) {
      value = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
    }
    sqlite3_finalize(statement);
    return value;
  }

  /// The number the map's meta holds under `key`; nullopt when missing or not a number.
  std::optional<uint64_t> metaNumber(const std::string& key) {
    const std::optional<std::string> text = meta(key);
    if (!text) return std::nullopt;
    try {
      return std::stoull(*text);
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }

  /// Sets count and last_id. Keyframes are only ever appended, so the saved search rows' seal
  /// (vectors_rows keyframes up to vectors_last_id) stays true: only the keyframes after it are
  /// counted, which spares reading every row of a large map (seconds at 1 000 000).
  void countKeyframes() {
    const std::optional<uint64_t> sealed_rows = metaNumber("vectors_rows");
    const std::optional<uint64_t> sealed_last = metaNumber("vectors_last_id");
    bool sealed = false;
    if (sealed_rows && sealed_last && *sealed_rows > 0) {
      sqlite3_stmt* at = prepare("SELECT 1 FROM keyframes WHERE id = ?");
      sqlite3_bind_int64(at, 1, static_cast<sqlite3_int64>(*sealed_last));
      sealed = sqlite3_step(at) == SQLITE_ROW;
      sqlite3_finalize(at);
    }
    sqlite3_stmt* counted = prepare("SELECT COUNT(*) FROM keyframes WHERE id > ?");
    sqlite3_bind_int64(counted, 1, sealed ? static_cast<sqlite3_int64>(*sealed_last) : -1);
    if (sqlite3_step(counted) == SQLITE_ROW) {
      count = static_cast<size_t>(sqlite3_column_int64(counted, 0)) + (sealed ? *sealed_rows : 0);
    }
    sqlite3_finalize(counted);
    sqlite3_stmt* last = prepare("SELECT MAX(id) FROM keyframes");
    if (sqlite3_step(last) == SQLITE_ROW && sqlite3_column_type(last, 0) != SQLITE_NULL) {
      last_id = static_cast<uint64_t>(sqlite3_column_int64(last, 0));
    }
    sqlite3_finalize(last);
  }

  bool hasTable(const char* name) {
    sqlite3_stmt* statement =
        prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?");
    sqlite3_bind_text(statement, 1, name, -1, SQLITE_TRANSIENT);
    const bool found = sqlite3_step(statement) == SQLITE_ROW;
    sqlite3_finalize(statement);
    return found;
  }

  void setMeta(const std::string& key, const std::string& value) {
    sqlite3_stmt* statement = prepare("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)");
    sqlite3_bind_text(statement, 1, key.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(statement, 2, value.c_str(), -1, SQLITE_TRANSIENT);
    const int status = sqlite3_step(statement);
    sqlite3_finalize(statement);
    if (status != SQLITE_DONE) fail("cannot write its settings");
  }
};

/// The integrity check of a map that existed before this open: the rows sealed at its last clean
/// shutdown against the seal's checksum, then SQLite's quick_check of the database file's pages,
/// read through a connection of its own that takes no lock (nothing is written to the file while
/// it runs: keyframes are held, and a log left by a crash was checkpointed before it started).
struct KeyframeStore::IntegrityCheck {
  std::string map_path;
  std::shared_ptr<const vector_file::Mapped> rows;  ///< Null when nothing was sealed.
  uint64_t entries = 0;
  uint32_t expected = 0;
  std::string rows_damaged;  ///< The message should the rows not match their seal.
  std::atomic<MapCheck> state{MapCheck::kPending};
  std::atomic<bool> stop{false};
  std::thread thread;
  bool background = false;  ///< Started by startIntegrityCheck(): a retry runs on a thread too.
  std::chrono::steady_clock::time_point deferred_at;  ///< When it was last deferred.

  /// Reads the rows and pages and sets `state`; leaves it when stopped first.
  void run();
  /// Why it failed (any thread); "" unless it did.
  std::string problem() const {
    MutexLock lock(problem_mutex);
    return problem_text;
  }
  /// The check's thread: it failed, for `why`.
  void fail(const std::string& why) {
    {
      MutexLock lock(problem_mutex);
      problem_text = why;
    }
    state = MapCheck::kFailed;
  }
  /// It could not run for the disk's sake (`why`): not damage, tried again later.
  void defer(const std::string& why) {
    {
      MutexLock lock(problem_mutex);
      problem_text = why;
    }
    deferred_at = std::chrono::steady_clock::now();
    state = MapCheck::kDeferred;
  }
  // Under a lock of its own, so that no reader depends on the order of `state`'s writes.
  mutable Mutex problem_mutex;
  std::string problem_text GUARDED_BY(problem_mutex);

  /// Stops a running check and waits for its thread.
  void halt() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  ~IntegrityCheck() { halt(); }
};

}  // namespace landmark_loop_closure
