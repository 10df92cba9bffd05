// Opening a map: the checks before SQLite sees the path, the schema and the integrity check set
// up, and closing it. Split from keyframe_store.cpp (writing and reading keyframes).
#include "landmark_loop_closure/database/keyframe_store.h"

#include "database/keyframe_codec.h"
#include "database/store_connection.h"
#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/database/map_file_safety.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>

namespace landmark_loop_closure {

/// Refuses what is not a regular file before SQLite opens it: opening a FIFO blocks until a
/// writer comes, a device or directory is never a map.
void checkMapPath(const std::string& path) {
  struct stat status;
  if (::stat(path.c_str(), &status) == 0) {
    if (!S_ISREG(status.st_mode)) throw storeError(path, "is not a regular file");
    if (::access(path.c_str(), R_OK | W_OK) != 0) {
      throw storeError(path, std::string("cannot be read and written: ") + std::strerror(errno));
    }
    return;
  }
  if (errno != ENOENT) throw storeError(path, std::strerror(errno));
  std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (folder.empty()) folder = ".";
  if (::access(folder.c_str(), W_OK) != 0) {
    throw storeError(
        path, "its folder " + folder.string() + " cannot be written: " + std::strerror(errno));
  }
}

namespace {

// An existing file that is not an SQLite database (or is empty) is no map: refused before SQLite
// opens it, which would take an empty file for a new database and write one into it.
void refuseForeignFile(const std::string& path) {
  switch (fileStartOf(path)) {
    case FileStart::kEmpty:
      throw storeError(
          path, "is an empty file, not a map (a new map is made at a path where no file is)");
    case FileStart::kOther:
      throw storeError(path, "is not a map (not an SQLite database); it is left as it is");
    case FileStart::kUnreadable:  // checkMapPath() already named why it cannot be read.
    case FileStart::kSqlite:
    case FileStart::kOldMap:  // Named by openChecked(), with how to convert it.
      return;
  }
}

}  // namespace

std::unique_ptr<KeyframeStore> KeyframeStore::open(const std::string& path,
                                                   const std::string& descriptor_identity,
                                                   int global_dimension) {
  auto store = openChecked(path, &descriptor_identity, global_dimension);
  // A save killed midway (the search files at shutdown, a copy onto this path) leaves its
  // temporary file; this process holds the map now, so they are nobody's.
  for (const std::string& leftover :
       {store->graphPath() + ".tmp", store->summariesPath() + ".tmp", store->vectorsPath() + ".tmp",
        path + ".partial", path + ".partial-vectors"}) {
    std::error_code error;
    if (std::filesystem::is_regular_file(leftover, error) &&
        std::filesystem::remove(leftover, error)) {
      store->leftovers_removed_.push_back(leftover);
    }
  }
  return store;
}

std::unique_ptr<KeyframeStore> KeyframeStore::openExisting(const std::string& path) {
  if (!std::filesystem::exists(path)) throw storeError(path, "does not exist");
  auto store = openChecked(path, nullptr, 0);
  store->checkIntegrity();
  return store;
}

KeyframeRecord KeyframeStore::asStored(const KeyframeRecord& keyframe) {
  KeyframeRecord stored = keyframe;
  const std::vector<uint8_t> record = database_payload::encodeRecord(keyframe);
  database_payload::decodeRecord(record.data(), record.size(), &stored);
  stored.descriptor.global =
      QuantizedVectors::decode(QuantizedVectors::encode(keyframe.descriptor.global).data(),
                               static_cast<int>(keyframe.descriptor.global.size()));
  return stored;
}

bool KeyframeStore::isOldMapFile(const std::string& path) {
  return fileStartOf(path) == FileStart::kOldMap;
}

std::unique_ptr<KeyframeStore> KeyframeStore::openChecked(const std::string& path,
                                                          const std::string* descriptor_identity,
                                                          int global_dimension) {
  checkMapPath(path);
  const bool existed = std::filesystem::exists(path);
  if (!existed) {
    // A log left by an earlier map at this path would be replayed into the new one; it is
    // someone's data (the last commits of a map moved away without it), never deleted here.
    for (const char* journal : {"-wal", "-shm", "-journal"}) {
      std::error_code absent;
      if (std::filesystem::exists(path + journal, absent)) {
        throw storeError(path, "cannot start here: " + path + journal +
                                   " exists without its map (a journal holding another map's "
                                   "last commits); move it away first, it is never deleted");
      }
    }
  } else {
    refuseForeignFile(path);
  }
  if (isOldMapFile(path)) {
    throw storeError(path,
                     "is a map file of the earlier format; convert it once with "
                     "`rosrun landmark_loop_closure lcd_db convert " +
                         path + " NEW_PATH`");
  }
  auto connection = std::make_unique<Connection>();
  connection->path = path;
  if (sqlite3_open_v2(path.c_str(), &connection->db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    connection->fail("cannot be opened");
  }
  // Exclusive locking: the lock taken below is held until close, so a second node fails at once
  // instead of interleaving keyframe ids; WAL commits append, so a killed writer never leaves a
  // map that does not open; synchronous NORMAL survives a killed process (a power cut may lose
  // the last commits, never the file).
  connection->execute("PRAGMA locking_mode = EXCLUSIVE", "cannot be locked");
  // A new map's pages: records spill over whole 2 KB pages with less left empty in the last one
  // than 4 KB pages leave (25.2 against 25.6 KB per keyframe in lcd_bench_map). No effect on an
  // existing map.
  connection->execute("PRAGMA page_size = 2048", "cannot be configured");
  if (existed && !connection->hasTable("meta")) {
    // Another program's database: nothing of ours is created in it (the log's mode below would
    // already change its header).
    throw storeError(path, "is an SQLite database but not a keyframe map (it has no meta table)");
  }
  sqlite3_stmt* journal = connection->prepare("PRAGMA journal_mode = WAL");
  const bool wal =
      sqlite3_step(journal) == SQLITE_ROW &&
      std::string(reinterpret_cast<const char*>(sqlite3_column_text(journal, 0))) == "wal";
  sqlite3_finalize(journal);
  if (!wal) connection->fail("cannot use a write-ahead log");
  connection->execute("PRAGMA synchronous = NORMAL", "cannot be configured");
  connection->execute("BEGIN IMMEDIATE", "cannot be locked");
  connection->execute(
      "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS keyframes (id INTEGER PRIMARY KEY, session INTEGER NOT NULL, "
      "stamp REAL NOT NULL, motion BLOB NOT NULL, search_row INTEGER NOT NULL, "
      "row_checksum INTEGER NOT NULL);"
      "CREATE TABLE IF NOT EXISTS records (id INTEGER PRIMARY KEY, record BLOB NOT NULL)",
      "cannot be written");
  const std::optional<std::string> version = connection->meta("format_version");
  if (!version && descriptor_identity == nullptr) {
    throw storeError(path, "is not a keyframe map (it has no settings)");
  }
  if (!version) {
    connection->execute(kCreateStampsTable, "cannot be written");
    connection->setMeta("format_version", std::to_string(kFormatVersion));
    connection->setMeta("descriptor_identity", *descriptor_identity);
    connection->setMeta("global_dimension", std::to_string(global_dimension));
    connection->setMeta("map_id", std::to_string(drawMapId()));
  } else {
    int stored_version = 0;
    try {
      stored_version = std::stoi(*version);
    } catch (const std::exception&) {
      throw storeError(path, "has a damaged format_version '" + *version + "'");
    }
    if (stored_version > kFormatVersion) {
      throw storeError(path, "was written by a newer version (format " + *version + ", this is " +
                                 std::to_string(kFormatVersion) + ")");
    }
    if (stored_version < kFormatVersion) {
      throw storeError(path, "is a map of the earlier format " + *version +
                                 "; convert it once with `rosrun landmark_loop_closure lcd_db "
                                 "convert " +
                                 path + " NEW_PATH`");
    }
    const std::string stored_identity = connection->meta("descriptor_identity").value_or("");
    if (descriptor_identity != nullptr && stored_identity != *descriptor_identity) {
      // Name the settings that differ, so a changed default or setting is found at a glance.
      const std::string differences =
          keyValueDifferences(stored_identity, *descriptor_identity, "the map", "this node");
      throw storeError(
          path,
          "holds keyframes of other descriptors (" +
              (differences.empty() ? stored_identity + "; this node uses " + *descriptor_identity
                                   : differences) +
              "): set them as the map has them to open it, or name another map file");
    }
    const std::string stored_dimension = connection->meta("global_dimension").value_or("");
    if (descriptor_identity == nullptr) {
      global_dimension = std::atoi(stored_dimension.c_str());
    } else if (stored_dimension != std::to_string(global_dimension)) {
      throw storeError(path, "holds global descriptors of " + stored_dimension + " values, not " +
                                 std::to_string(global_dimension));
    }
  }
  connection->execute("COMMIT", "cannot be written");
  const std::optional<uint64_t> map_id = connection->metaNumber("map_id");

  connection->countKeyframes();
  connection->insert = connection->prepare(
      "INSERT INTO keyframes (id, session, stamp, motion, search_row, row_checksum) "
      "VALUES (?, ?, ?, ?, ?, ?)");
  connection->insert_record = connection->prepare("INSERT INTO records (id, record) VALUES (?, ?)");
  connection->has_stamps = connection->hasTable("keyframe_stamps");
  prepareSelect(connection.get());
  const std::string identity = descriptor_identity != nullptr
                                   ? *descriptor_identity
                                   : connection->meta("descriptor_identity").value_or("");
  std::unique_ptr<KeyframeStore> store(new KeyframeStore(path, std::move(connection)));
  store->descriptor_identity_ = identity;
  store->global_dimension_ = global_dimension;
  store->map_id_ = map_id.value_or(drawMapId());
  store->map_id_unsaved_ = !map_id;
  store->reserved_through_ = store->connection_->metaNumber("ids_reserved_through");
  store->reserved_in_file_ = store->reserved_through_;
  if (const std::optional<uint64_t> sessions =
          store->connection_->metaNumber("sessions_reserved_through");
      sessions && *sessions <= std::numeric_limits<uint32_t>::max()) {
    store->sessions_reserved_through_ = static_cast<uint32_t>(*sessions);
  }
  if (existed) {
    store->check_ = std::make_unique<IntegrityCheck>();
    store->check_->map_path = path;
  }
  store->openRows();
  return store;
}

uint64_t KeyframeStore::drawMapId() {
  std::random_device device;
  std::uniform_int_distribution<uint64_t> bits(1, std::numeric_limits<uint64_t>::max());
  return bits(device);
}

KeyframeStore::KeyframeStore(std::string path, std::unique_ptr<Connection> connection)
    : path_(std::move(path)), connection_(std::move(connection)) {}

KeyframeStore::~KeyframeStore() {
  try {
    settleBeforeClose();
  } catch (const std::exception&) {
    // A full disk: what was held is lost, as a killed process loses its queue.
  }
  if (integrityCheck() == MapCheck::kFailed) {
    // Closing checkpoints the log into the file: a damaged map is left exactly as it was.
    sqlite3_db_config(connection_->db, SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
  }
}

}  // namespace landmark_loop_closure
