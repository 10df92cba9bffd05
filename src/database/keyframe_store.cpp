#include "landmark_loop_closure/database/keyframe_store.h"

#include "common/crc32c.h"
#include "database/keyframe_codec.h"
#include "database/store_connection.h"
#include "database/vector_file.h"
#include "landmark_loop_closure/common/durable_file.h"
#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/database/map_file_safety.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

#include <sqlite3.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

// The columns readRow() reads, after `prefix` (the id, or nothing), for keyframes `where`.
std::string selectKeyframes(bool has_stamps, const char* prefix, const char* where) {
  return std::string("SELECT ") + prefix +
         "k.session, k.stamp, k.motion, k.search_row, k.row_checksum, r.record, " +
         (has_stamps ? "s.stamp_ns" : "NULL") + " FROM keyframes k JOIN records r ON r.id = k.id " +
         (has_stamps ? "LEFT JOIN keyframe_stamps s ON s.id = k.id " : "") + where;
}

// Runs a prepared insert once with its bindings and clears it; true when it stored the row.
bool insertRow(sqlite3_stmt* statement) {
  const int status = sqlite3_step(statement);
  sqlite3_reset(statement);
  sqlite3_clear_bindings(statement);
  return status == SQLITE_DONE;
}

// A keyframe's id, session, stamp, pose and path from a `keyframes` row whose session, stamp and
// motion columns start at `first_column` (both store formats).
KeyframeRecord readSummaryColumns(sqlite3_stmt* row, int first_column, uint64_t id) {
  KeyframeRecord keyframe;
  keyframe.id = id;
  keyframe.session = static_cast<uint32_t>(sqlite3_column_int64(row, first_column));
  keyframe.stamp = sqlite3_column_double(row, first_column + 1);
  database_payload::decodeMotion(
      static_cast<const uint8_t*>(sqlite3_column_blob(row, first_column + 2)),
      static_cast<size_t>(sqlite3_column_bytes(row, first_column + 2)), &keyframe);
  return keyframe;
}

// A keyframe of the earlier store format 2, its global row in the `vector` column.
KeyframeRecord readFormat2Row(sqlite3_stmt* row, int first_column, uint64_t id) {
  KeyframeRecord keyframe = readSummaryColumns(row, first_column, id);
  const auto blob = [&](int column) {
    return static_cast<const uint8_t*>(sqlite3_column_blob(row, first_column + column));
  };
  const auto bytes = [&](int column) {
    return static_cast<size_t>(sqlite3_column_bytes(row, first_column + column));
  };
  const int dimension = static_cast<int>(bytes(3)) - static_cast<int>(sizeof(float));
  if (dimension <= 0) throw database_payload::FormatError("its global vector is empty");
  keyframe.descriptor.global = QuantizedVectors::decode(blob(3), dimension);
  database_payload::decodeRecord(blob(4), bytes(4), &keyframe);
  return keyframe;
}

}  // namespace

void KeyframeStore::prepareSelect(Connection* c) {
  sqlite3_finalize(c->select);
  c->select = nullptr;
  c->select = c->prepare(selectKeyframes(c->has_stamps, "", "WHERE k.id = ?").c_str());
}

void KeyframeStore::addStampTable() {
  Connection& c = *connection_;
  if (c.has_stamps) return;
  // Its own transaction, before the keyframe's: a map of an earlier version gets it with its
  // first keyframe after the check, so a damaged map is never written to.
  c.execute(kCreateStampsTable, "cannot be written");
  c.has_stamps = true;
  prepareSelect(&c);
}

KeyframeRecord KeyframeStore::readRow(sqlite3_stmt* row, int first_column, uint64_t id) const {
  KeyframeRecord keyframe = readSummaryColumns(row, first_column, id);
  keyframe.stamp_ns = sqlite3_column_type(row, first_column + 6) == SQLITE_INTEGER
                          ? sqlite3_column_int64(row, first_column + 6)
                          : std::llround(keyframe.stamp * 1e9);
  const auto position = static_cast<size_t>(sqlite3_column_int64(row, first_column + 3));
  const auto checksum = static_cast<uint32_t>(sqlite3_column_int64(row, first_column + 4));
  const std::vector<uint8_t> entry = rows_->read(position);
  if (entry.empty() || crc32c(0, entry.data(), entry.size()) != checksum) {
    throw database_payload::FormatError("its search row in " + rows_->path() + " is damaged");
  }
  keyframe.descriptor.global = QuantizedVectors::decode(entry.data(), global_dimension_);
  database_payload::decodeRecord(
      static_cast<const uint8_t*>(sqlite3_column_blob(row, first_column + 5)),
      static_cast<size_t>(sqlite3_column_bytes(row, first_column + 5)), &keyframe);
  return keyframe;
}

uint32_t KeyframeStore::insert(const KeyframeRecord& keyframe) {
  Connection& c = *connection_;
  if (c.last_id && keyframe.id <= *c.last_id) {
    throw storeError(path_, "keyframe id " + std::to_string(keyframe.id) +
                                " is not after the last stored " + std::to_string(*c.last_id));
  }
  if (static_cast<int>(keyframe.descriptor.global.size()) != global_dimension_) {
    throw storeError(path_, "keyframe " + std::to_string(keyframe.id) + " has a global vector of " +
                                std::to_string(keyframe.descriptor.global.size()) +
                                " values, not " + std::to_string(global_dimension_));
  }
  const std::vector<uint8_t> motion = database_payload::encodeMotion(keyframe);
  const std::vector<uint8_t> entry =
      vector_file::entry(QuantizedVectors::encode(keyframe.descriptor.global), keyframe);
  const std::vector<uint8_t> record = database_payload::encodeRecord(keyframe);
  // The search row is written first: a keyframe whose transaction commits always has one.
  const size_t position = c.count;
  try {
    rows_->write(position, entry.data());
  } catch (const std::exception& error) {
    throw storeError(path_,
                     "keyframe " + std::to_string(keyframe.id) + " not stored: " + error.what());
  }
  const uint32_t checksum = crc32c(0, entry.data(), entry.size());
  const auto id = static_cast<sqlite3_int64>(keyframe.id);
  sqlite3_bind_int64(c.insert, 1, id);
  sqlite3_bind_int64(c.insert, 2, keyframe.session);
  sqlite3_bind_double(c.insert, 3, keyframe.stamp);
  sqlite3_bind_blob(c.insert, 4, motion.data(), static_cast<int>(motion.size()), SQLITE_STATIC);
  sqlite3_bind_int64(c.insert, 5, static_cast<sqlite3_int64>(position));
  sqlite3_bind_int64(c.insert, 6, checksum);
  sqlite3_bind_int64(c.insert_record, 1, id);
  sqlite3_bind_blob(c.insert_record, 2, record.data(), static_cast<int>(record.size()),
                    SQLITE_STATIC);
  // OR REPLACE: an earlier version repairing the map removes keyframes, not their stamps.
  if (c.insert_stamp == nullptr) {
    c.insert_stamp =
        c.prepare("INSERT OR REPLACE INTO keyframe_stamps (id, stamp_ns) VALUES (?, ?)");
  }
  sqlite3_bind_int64(c.insert_stamp, 1, id);
  sqlite3_bind_int64(
      c.insert_stamp, 2,
      keyframe.stamp_ns != 0 ? keyframe.stamp_ns : std::llround(keyframe.stamp * 1e9));
  if (!insertRow(c.insert) || !insertRow(c.insert_record) || !insertRow(c.insert_stamp)) {
    c.fail("keyframe " + std::to_string(keyframe.id) + " not stored");
  }
  if (map_id_unsaved_) c.setMeta("map_id", std::to_string(map_id_));
  return checksum;
}

void KeyframeStore::reserveIdsThrough(uint64_t id) {
  if (!reserved_through_ || id > *reserved_through_) {
    reserved_through_ = id;
    reservation_unsaved_ = true;
  }
  if (!reservation_unsaved_) return;
  if (!retryDeferredCheck()) {
    throw storeError(path_, "keyframe ids through " + std::to_string(id) +
                                " not reserved: " + integrityDeferredBy());
  }
  if (integrityCheck() == MapCheck::kPassed) saveReservation();
}

void KeyframeStore::reserveSession(uint32_t session) {
  if (sessions_reserved_through_ && session <= *sessions_reserved_through_) return;
  sessions_reserved_through_ = session;
  reservation_unsaved_ = true;
}

void KeyframeStore::saveReservation() {
  if (!reservation_unsaved_) return;
  Connection& c = *connection_;
  c.execute("BEGIN IMMEDIATE", "cannot write its reservations");
  try {
    if (reserved_through_) c.setMeta("ids_reserved_through", std::to_string(*reserved_through_));
    if (sessions_reserved_through_) {
      c.setMeta("sessions_reserved_through", std::to_string(*sessions_reserved_through_));
    }
    if (map_id_unsaved_) c.setMeta("map_id", std::to_string(map_id_));
    c.execute("COMMIT", "cannot write its reservations");
  } catch (...) {
    if (sqlite3_get_autocommit(c.db) == 0) {
      sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    throw;
  }
  map_id_unsaved_ = false;
  reservation_unsaved_ = false;
  reserved_in_file_ = reserved_through_;
}

std::optional<uint64_t> KeyframeStore::idsReservedThrough() const { return reserved_through_; }

std::optional<uint64_t> KeyframeStore::idsReservedInFile() const { return reserved_in_file_; }

std::optional<uint64_t> KeyframeStore::lastCommittedId() const { return connection_->last_id; }

void KeyframeStore::add(const KeyframeRecord& keyframe) {
  Connection& c = *connection_;
  const std::string not_stored = "keyframe " + std::to_string(keyframe.id) + " not stored";
  if (integrityCheck() == MapCheck::kPending) {
    try {
      checkIntegrity();  // Tools add without starting it; a node starts it at open.
    } catch (const std::runtime_error&) {
      // kFailed: refused below.
    }
  }
  if (!retryDeferredCheck()) throw storeError(path_, not_stored + ": " + integrityDeferredBy());
  switch (integrityCheck()) {
    case MapCheck::kDeferred:
      throw storeError(path_, not_stored + ": " + integrityDeferredBy());
    case MapCheck::kFailed:
      throw storeError(path_, not_stored + ": the map is damaged and is left as it is");
    case MapCheck::kRunning:
    case MapCheck::kPending: {  // Stopped before it finished (the store is closing).
      const std::optional<uint64_t> last = held_.empty() ? c.last_id : held_.back().id;
      if (last && keyframe.id <= *last) {
        throw storeError(path_, "keyframe id " + std::to_string(keyframe.id) +
                                    " is not after the last stored " + std::to_string(*last));
      }
      held_.push_back(keyframe);
      return;
    }
    case MapCheck::kPassed:
      commitHeld();
      break;
  }
  addStampTable();
  c.execute("BEGIN IMMEDIATE", not_stored);
  uint32_t checksum = 0;
  try {
    checksum = insert(keyframe);
    c.execute("COMMIT", not_stored);
    map_id_unsaved_ = false;
  } catch (...) {
    // A failed COMMIT (disk full) leaves the transaction open: closed here, so the next keyframe
    // is stored once there is room again.
    if (sqlite3_get_autocommit(c.db) == 0)
      sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  c.last_id = keyframe.id;
  ++c.count;
  entries_checksum_ =
      crc32cCombine(entries_checksum_, checksum,
                    static_cast<uint64_t>(vector_file::entryBytes(global_dimension_)));
}

void KeyframeStore::addAll(const KeyframeDatabase& database) {
  std::vector<std::shared_ptr<const KeyframeRecord>> keyframes(database.size());
  for (size_t i = 0; i < database.size(); ++i) {
    keyframes[i] = database.record(i);
    if (!keyframes[i]) {
      throw storeError(path_, "keyframe " + std::to_string(database.summary(i).id) +
                                  " could not be read to copy it");
    }
  }
  insertInOneTransaction(keyframes.size(), [&](size_t i) { return keyframes[i].get(); });
}

void KeyframeStore::insertInOneTransaction(
    size_t count, const std::function<const KeyframeRecord*(size_t)>& keyframe) {
  Connection& c = *connection_;
  const std::optional<uint64_t> last_id = c.last_id;
  const size_t committed = c.count;
  uint32_t entries_checksum = entries_checksum_;
  addStampTable();
  c.execute("BEGIN IMMEDIATE", "cannot be written");
  try {
    for (size_t i = 0; i < count; ++i) {
      const KeyframeRecord& next = *keyframe(i);
      entries_checksum =
          crc32cCombine(entries_checksum, insert(next),
                        static_cast<uint64_t>(vector_file::entryBytes(global_dimension_)));
      c.last_id = next.id;
      ++c.count;
    }
    c.execute("COMMIT", "cannot be written");
    map_id_unsaved_ = false;
  } catch (...) {
    sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    c.last_id = last_id;
    c.count = committed;
    throw;
  }
  entries_checksum_ = entries_checksum;
}

void KeyframeStore::forEach(const std::function<void(KeyframeRecord)>& visit) const {
  Connection& c = *connection_;
  sqlite3_stmt* statement =
      c.prepare(selectKeyframes(c.has_stamps, "k.id, ", "ORDER BY k.id").c_str());
  int status;
  while ((status = sqlite3_step(statement)) == SQLITE_ROW) {
    const auto id = static_cast<uint64_t>(sqlite3_column_int64(statement, 0));
    KeyframeRecord keyframe;
    try {
      keyframe = readRow(statement, 1, id);
    } catch (const std::exception& error) {
      sqlite3_finalize(statement);
      throw storeError(path_, "keyframe " + std::to_string(id) + " is damaged: " + error.what());
    }
    visit(std::move(keyframe));
  }
  sqlite3_finalize(statement);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
}

void KeyframeStore::readEarlierFormat(const std::string& path, std::string* descriptor_identity,
                                      int* global_dimension,
                                      const std::function<void(KeyframeRecord)>& visit) {
  checkMapPath(path);
  Connection c;
  c.path = path;
  if (sqlite3_open_v2(path.c_str(), &c.db, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr) !=
      SQLITE_OK) {
    c.fail("cannot be opened");
  }
  const std::string version = c.meta("format_version").value_or("");
  if (version != "1" && version != "2") {
    throw storeError(path, "is not a map of store format 1 or 2");
  }
  *descriptor_identity = c.meta("descriptor_identity").value_or("");
  *global_dimension = std::atoi(c.meta("global_dimension").value_or("0").c_str());
  // Format 1: whole keyframes in the earlier file's layout; format 2: the global row beside the
  // summary, the rest in `records`.
  sqlite3_stmt* statement = c.prepare(
      version == "1" ? "SELECT id, record FROM keyframes ORDER BY id"
                     : "SELECT k.id, k.session, k.stamp, k.motion, k.vector, r.record FROM "
                       "keyframes k JOIN records r ON r.id = k.id ORDER BY k.id");
  int status;
  while ((status = sqlite3_step(statement)) == SQLITE_ROW) {
    KeyframeRecord keyframe;
    try {
      if (version == "1") {
        keyframe = database_payload::decodeKeyframe(
            static_cast<const uint8_t*>(sqlite3_column_blob(statement, 1)),
            static_cast<size_t>(sqlite3_column_bytes(statement, 1)));
      } else {
        keyframe =
            readFormat2Row(statement, 1, static_cast<uint64_t>(sqlite3_column_int64(statement, 0)));
      }
    } catch (const std::exception& error) {
      const int64_t id = sqlite3_column_int64(statement, 0);
      sqlite3_finalize(statement);
      throw storeError(path, "keyframe " + std::to_string(id) + " is damaged: " + error.what());
    }
    visit(std::move(keyframe));
  }
  sqlite3_finalize(statement);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
}

void KeyframeStore::replaceFile(const std::string& from, const std::string& to) {
  std::error_code error;
  for (const char* journal : {"-wal", "-shm", "-journal", "-graph", "-vectors"}) {
    std::filesystem::remove(to + journal, error);
  }
  // Two renames: a crash between them leaves a map and rows file that do not match, which opening
  // refuses (checksums) instead of misreading.
  if (std::filesystem::exists(from + "-vectors")) {
    std::filesystem::rename(from + "-vectors", to + "-vectors", error);
    if (error) throw storeError(to, "cannot be written: " + error.message());
  }
  std::filesystem::rename(from, to, error);
  if (error) throw storeError(to, "cannot be written: " + error.message());
  // The renames reach the disk with the folder: a power cut after this keeps the new map.
  if (const std::string unsynced = syncFolderOf(to); !unsynced.empty()) {
    throw storeError(to, "written, but " + unsynced);
  }
}

std::optional<KeyframeRecord> KeyframeStore::get(uint64_t id) const {
  for (const KeyframeRecord& held : held_) {
    if (held.id == id) return asStored(held);
  }
  Connection& c = *connection_;
  sqlite3_bind_int64(c.select, 1, static_cast<sqlite3_int64>(id));
  std::optional<KeyframeRecord> keyframe;
  const int status = sqlite3_step(c.select);
  try {
    if (status == SQLITE_ROW) keyframe = readRow(c.select, 0, id);
  } catch (const std::exception& error) {
    sqlite3_reset(c.select);
    throw storeError(path_, "keyframe " + std::to_string(id) + " is damaged: " + error.what());
  }
  sqlite3_reset(c.select);
  if (status != SQLITE_ROW && status != SQLITE_DONE) c.fail("cannot read keyframe");
  return keyframe;
}

size_t KeyframeStore::size() const { return connection_->count + held_.size(); }

std::vector<uint32_t> KeyframeStore::sessions() const {
  Connection& c = *connection_;
  sqlite3_stmt* statement = c.prepare("SELECT DISTINCT session FROM keyframes ORDER BY session");
  std::vector<uint32_t> sessions;
  while (sqlite3_step(statement) == SQLITE_ROW) {
    sessions.push_back(static_cast<uint32_t>(sqlite3_column_int64(statement, 0)));
  }
  sqlite3_finalize(statement);
  return sessions;
}

}  // namespace landmark_loop_closure
