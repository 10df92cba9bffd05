#include "landmark_loop_closure/database/keyframe_store.h"

#include "database/keyframe_codec.h"

#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

using database_payload::decode;
using database_payload::encode;

std::runtime_error storeError(const std::string& path, const std::string& reason) {
  return std::runtime_error("map " + path + ": " + reason);
}

/// Refuses what is not a regular file before SQLite opens it: opening a FIFO blocks until a
/// writer comes, a device or directory is never a map.
void checkPath(const std::string& path) {
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

std::vector<uint8_t> encodeGlobal(const std::vector<float>& global) {
  std::vector<uint8_t> bytes(global.size() * 4);
  for (size_t i = 0; i < global.size(); ++i) {
    uint32_t bits = 0;
    std::memcpy(&bits, &global[i], 4);
    encode(bits, bytes.data() + 4 * i);
  }
  return bytes;
}

std::vector<float> decodeGlobal(const uint8_t* bytes, size_t size) {
  std::vector<float> global(size / 4);
  for (size_t i = 0; i < global.size(); ++i) {
    const uint32_t bits = decode<uint32_t>(bytes + 4 * i);
    std::memcpy(&global[i], &bits, 4);
  }
  return global;
}

}  // namespace

struct KeyframeStore::Connection {
  sqlite3* db = nullptr;
  sqlite3_stmt* insert = nullptr;
  sqlite3_stmt* select = nullptr;
  std::string path;
  size_t count = 0;
  std::optional<uint64_t> last_id;

  ~Connection() {
    sqlite3_finalize(insert);
    sqlite3_finalize(select);
    if (db != nullptr) sqlite3_close(db);  // The last connection checkpoints the WAL.
  }

  [[noreturn]] void fail(const std::string& what) const {
    const int code = db != nullptr ? sqlite3_errcode(db) : SQLITE_ERROR;
    if (code == SQLITE_BUSY || code == SQLITE_LOCKED) {
      throw storeError(path, "is open in another process (one node per map)");
    }
    if (code == SQLITE_FULL) throw storeError(path, what + ": the disk is full");
    throw storeError(path, what + ": " + (db != nullptr ? sqlite3_errmsg(db) : "no connection"));
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

  void setMeta(const std::string& key, const std::string& value) {
    sqlite3_stmt* statement = prepare("INSERT INTO meta (key, value) VALUES (?, ?)");
    sqlite3_bind_text(statement, 1, key.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(statement, 2, value.c_str(), -1, SQLITE_TRANSIENT);
    const int status = sqlite3_step(statement);
    sqlite3_finalize(statement);
    if (status != SQLITE_DONE) fail("cannot write its settings");
  }
};

std::unique_ptr<KeyframeStore> KeyframeStore::open(const std::string& path,
                                                   const std::string& descriptor_identity,
                                                   int global_dimension) {
  return openChecked(path, &descriptor_identity, global_dimension);
}

std::unique_ptr<KeyframeStore> KeyframeStore::openExisting(const std::string& path) {
  if (!std::filesystem::exists(path)) throw storeError(path, "does not exist");
  return openChecked(path, nullptr, 0);
}

bool KeyframeStore::isOldMapFile(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return false;
  char magic[8] = {};
  const bool read = std::fread(magic, 1, 8, file) == 8;
  std::fclose(file);
  return read && std::memcmp(magic, "LLCKFDB\n", 8) == 0;
}

std::unique_ptr<KeyframeStore> KeyframeStore::openChecked(const std::string& path,
                                                          const std::string* descriptor_identity,
                                                          int global_dimension) {
  checkPath(path);
  if (!std::filesystem::exists(path)) {
    // A log left by an earlier map at this path would be replayed into the new one.
    std::error_code ignored;
    for (const char* journal : {"-wal", "-shm", "-journal"}) {
      std::filesystem::remove(path + journal, ignored);
    }
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
      "stamp REAL NOT NULL, global BLOB NOT NULL, record BLOB NOT NULL);"
      "CREATE TABLE IF NOT EXISTS graph (slot INTEGER PRIMARY KEY CHECK (slot = 0), "
      "identity TEXT NOT NULL, keyframes INTEGER NOT NULL, bytes BLOB NOT NULL)",
      "cannot be written");
  const std::optional<std::string> version = connection->meta("format_version");
  if (!version && descriptor_identity == nullptr) {
    throw storeError(path, "is not a keyframe map (it has no settings)");
  }
  if (!version) {
    connection->setMeta("format_version", std::to_string(kFormatVersion));
    connection->setMeta("descriptor_identity", *descriptor_identity);
    connection->setMeta("global_dimension", std::to_string(global_dimension));
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
    const std::string stored_identity = connection->meta("descriptor_identity").value_or("");
    if (descriptor_identity != nullptr && stored_identity != *descriptor_identity) {
      throw storeError(path, "holds keyframes of other descriptors (" + stored_identity +
                                 "; this node uses " + *descriptor_identity + ")");
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

  sqlite3_stmt* summary = connection->prepare("SELECT COUNT(*), MAX(id) FROM keyframes");
  if (sqlite3_step(summary) == SQLITE_ROW) {
    connection->count = static_cast<size_t>(sqlite3_column_int64(summary, 0));
    if (sqlite3_column_type(summary, 1) != SQLITE_NULL) {
      connection->last_id = static_cast<uint64_t>(sqlite3_column_int64(summary, 1));
    }
  }
  sqlite3_finalize(summary);
  connection->insert = connection->prepare(
      "INSERT INTO keyframes (id, session, stamp, global, record) VALUES (?, ?, ?, ?, ?)");
  connection->select = connection->prepare("SELECT record FROM keyframes WHERE id = ?");
  const std::string identity = descriptor_identity != nullptr
                                   ? *descriptor_identity
                                   : connection->meta("descriptor_identity").value_or("");
  std::unique_ptr<KeyframeStore> store(new KeyframeStore(path, std::move(connection)));
  store->descriptor_identity_ = identity;
  store->global_dimension_ = global_dimension;
  return store;
}

KeyframeStore::KeyframeStore(std::string path, std::unique_ptr<Connection> connection)
    : path_(std::move(path)), connection_(std::move(connection)) {}

KeyframeStore::~KeyframeStore() = default;

void KeyframeStore::add(const KeyframeRecord& keyframe) {
  Connection& c = *connection_;
  if (c.last_id && keyframe.id <= *c.last_id) {
    throw storeError(path_, "keyframe id " + std::to_string(keyframe.id) +
                                " is not after the last stored " + std::to_string(*c.last_id));
  }
  const std::vector<uint8_t> record = database_payload::encodeKeyframe(keyframe);
  const std::vector<uint8_t> global = encodeGlobal(keyframe.descriptor.global);
  sqlite3_bind_int64(c.insert, 1, static_cast<sqlite3_int64>(keyframe.id));
  sqlite3_bind_int64(c.insert, 2, keyframe.session);
  sqlite3_bind_double(c.insert, 3, keyframe.stamp);
  sqlite3_bind_blob(c.insert, 4, global.data(), static_cast<int>(global.size()), SQLITE_STATIC);
  sqlite3_bind_blob(c.insert, 5, record.data(), static_cast<int>(record.size()), SQLITE_STATIC);
  // Outside an explicit transaction the statement commits on its own.
  const int status = sqlite3_step(c.insert);
  sqlite3_reset(c.insert);
  sqlite3_clear_bindings(c.insert);
  if (status != SQLITE_DONE) c.fail("keyframe " + std::to_string(keyframe.id) + " not stored");
  c.last_id = keyframe.id;
  ++c.count;
}

void KeyframeStore::addAll(const KeyframeDatabase& database) {
  Connection& c = *connection_;
  const std::optional<uint64_t> last_id = c.last_id;
  const size_t count = c.count;
  c.execute("BEGIN IMMEDIATE", "cannot be written");
  try {
    for (size_t i = 0; i < database.size(); ++i) add(database.at(i));
  } catch (...) {
    sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    c.last_id = last_id;
    c.count = count;
    throw;
  }
  c.execute("COMMIT", "cannot be written");
}

void KeyframeStore::forEach(const std::function<void(KeyframeRecord)>& visit) const {
  Connection& c = *connection_;
  sqlite3_stmt* statement = c.prepare("SELECT id, record FROM keyframes ORDER BY id");
  int status;
  while ((status = sqlite3_step(statement)) == SQLITE_ROW) {
    const auto* bytes = static_cast<const uint8_t*>(sqlite3_column_blob(statement, 1));
    const size_t size = static_cast<size_t>(sqlite3_column_bytes(statement, 1));
    KeyframeRecord keyframe;
    try {
      keyframe = database_payload::decodeKeyframe(bytes, size);
    } catch (const std::exception& error) {
      const int64_t id = sqlite3_column_int64(statement, 0);
      sqlite3_finalize(statement);
      throw storeError(path_, "keyframe " + std::to_string(id) + " is damaged: " + error.what());
    }
    visit(std::move(keyframe));
  }
  sqlite3_finalize(statement);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
}

void KeyframeStore::copyTo(const std::string& target) const {
  const std::string partial = target + ".partial";
  std::filesystem::remove(partial);
  sqlite3* copy = nullptr;
  const auto fail = [&](const std::string& what) {
    const std::string reason = copy != nullptr ? sqlite3_errmsg(copy) : "cannot be created";
    if (copy != nullptr) sqlite3_close(copy);
    std::filesystem::remove(partial);
    throw storeError(target, what + ": " + reason);
  };
  if (sqlite3_open_v2(partial.c_str(), &copy, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                      nullptr) != SQLITE_OK) {
    fail("cannot be created");
  }
  sqlite3_backup* backup = sqlite3_backup_init(copy, "main", connection_->db, "main");
  if (backup == nullptr) fail("cannot be written");
  const int status = sqlite3_backup_step(backup, -1);
  sqlite3_backup_finish(backup);
  if (status != SQLITE_DONE) fail("cannot be written");
  sqlite3_close(copy);
  try {
    replaceFile(partial, target);
  } catch (...) {
    std::filesystem::remove(partial);
    throw;
  }
}

void KeyframeStore::replaceFile(const std::string& from, const std::string& to) {
  std::error_code error;
  for (const char* journal : {"-wal", "-shm", "-journal"}) {
    std::filesystem::remove(to + journal, error);
  }
  std::filesystem::rename(from, to, error);
  if (error) throw storeError(to, "cannot be written: " + error.message());
}

std::optional<KeyframeRecord> KeyframeStore::get(uint64_t id) const {
  Connection& c = *connection_;
  sqlite3_bind_int64(c.select, 1, static_cast<sqlite3_int64>(id));
  std::optional<KeyframeRecord> keyframe;
  const int status = sqlite3_step(c.select);
  try {
    if (status == SQLITE_ROW) {
      const auto* bytes = static_cast<const uint8_t*>(sqlite3_column_blob(c.select, 0));
      const size_t size = static_cast<size_t>(sqlite3_column_bytes(c.select, 0));
      keyframe = database_payload::decodeKeyframe(bytes, size);
    }
  } catch (const std::exception& error) {
    sqlite3_reset(c.select);
    throw storeError(path_, "keyframe " + std::to_string(id) + " is damaged: " + error.what());
  }
  sqlite3_reset(c.select);
  if (status != SQLITE_ROW && status != SQLITE_DONE) c.fail("cannot read keyframe");
  return keyframe;
}

void KeyframeStore::forEachGlobal(
    const std::function<void(uint64_t, uint32_t, double, std::vector<float>)>& visit) const {
  Connection& c = *connection_;
  sqlite3_stmt* statement =
      c.prepare("SELECT id, session, stamp, global FROM keyframes ORDER BY id");
  int status;
  while ((status = sqlite3_step(statement)) == SQLITE_ROW) {
    const auto* bytes = static_cast<const uint8_t*>(sqlite3_column_blob(statement, 3));
    const size_t size = static_cast<size_t>(sqlite3_column_bytes(statement, 3));
    visit(static_cast<uint64_t>(sqlite3_column_int64(statement, 0)),
          static_cast<uint32_t>(sqlite3_column_int64(statement, 1)),
          sqlite3_column_double(statement, 2), decodeGlobal(bytes, size));
  }
  sqlite3_finalize(statement);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
}

void KeyframeStore::saveGraph(const std::string& graph_identity, size_t keyframes,
                              const std::vector<uint8_t>& bytes) {
  Connection& c = *connection_;
  if (bytes.size() > static_cast<size_t>(sqlite3_limit(c.db, SQLITE_LIMIT_LENGTH, -1))) {
    throw storeError(path_, "the search graph (" + std::to_string(bytes.size() >> 20) +
                                " MB) is larger than one SQLite value; it is built at next start");
  }
  sqlite3_stmt* statement = c.prepare(
      "INSERT OR REPLACE INTO graph (slot, identity, keyframes, bytes) VALUES (0, ?, ?, ?)");
  sqlite3_bind_text(statement, 1, graph_identity.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(statement, 2, static_cast<sqlite3_int64>(keyframes));
  sqlite3_bind_blob64(statement, 3, bytes.data(), bytes.size(), SQLITE_STATIC);
  const int status = sqlite3_step(statement);
  sqlite3_finalize(statement);
  if (status != SQLITE_DONE) c.fail("the search graph not saved");
}

std::optional<std::vector<uint8_t>> KeyframeStore::loadGraph(
    const std::string& graph_identity) const {
  Connection& c = *connection_;
  sqlite3_stmt* statement =
      c.prepare("SELECT identity, keyframes, bytes FROM graph WHERE slot = 0");
  std::optional<std::vector<uint8_t>> bytes;
  if (sqlite3_step(statement) == SQLITE_ROW) {
    const std::string identity = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
    const auto keyframes = static_cast<size_t>(sqlite3_column_int64(statement, 1));
    if (identity == graph_identity && keyframes == c.count) {
      const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(statement, 2));
      bytes.emplace(data, data + sqlite3_column_bytes(statement, 2));
    }
  }
  sqlite3_finalize(statement);
  return bytes;
}

size_t KeyframeStore::size() const { return connection_->count; }

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
