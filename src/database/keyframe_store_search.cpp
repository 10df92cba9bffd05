// What search reads from a map: every keyframe's summary and 8-bit row at open (from the rows
// saved beside the map when they are this map's), and the search graph and rows saved at a clean
// shutdown.
#include "landmark_loop_closure/database/keyframe_store.h"

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "common/crc32c.h"
#include "database/keyframe_codec.h"
#include "database/store_connection.h"
#include "database/vector_file.h"

namespace landmark_loop_closure {

namespace {

// CRC-32C of a whole file, read in 1 MB pieces; nullopt when it cannot be read.
std::optional<uint32_t> fileChecksum(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return std::nullopt;
  std::vector<uint8_t> buffer(1 << 20);
  uint32_t crc = 0;
  size_t got = 0;
  while ((got = std::fread(buffer.data(), 1, buffer.size(), file)) > 0) {
    crc = crc32c(crc, buffer.data(), got);
  }
  const bool failed = std::ferror(file) != 0;
  std::fclose(file);
  if (failed) return std::nullopt;
  return crc;
}

std::optional<uint64_t> metaNumber(const std::optional<std::string>& text) {
  if (!text) return std::nullopt;
  try {
    return std::stoull(*text);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace

void KeyframeStore::forEachSummary(
    const std::function<void(const KeyframeSummary&, const uint8_t* vector_row, size_t row_bytes)>&
        visit) const {
  Connection& c = *connection_;
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(global_dimension_);
  // The rows saved beside the map at the last clean shutdown, when they are this map's: read from
  // there in one pass; the keyframes committed after them (a crash) from their database rows.
  std::optional<vector_file::Reader> saved;
  uint64_t saved_rows = 0;
  const std::optional<uint64_t> rows = metaNumber(c.meta("vectors_rows"));
  const std::optional<uint64_t> checksum = metaNumber(c.meta("vectors_checksum"));
  const std::optional<uint64_t> last_id = metaNumber(c.meta("vectors_last_id"));
  if (rows && checksum && last_id && *rows > 0 && *rows <= c.count) {
    saved.emplace(vectorsPath(), static_cast<uint32_t>(*checksum), global_dimension_);
    sqlite3_stmt* at = c.prepare("SELECT id FROM keyframes ORDER BY id LIMIT 1 OFFSET ?");
    sqlite3_bind_int64(at, 1, static_cast<sqlite3_int64>(*rows - 1));
    const bool same_keyframes = sqlite3_step(at) == SQLITE_ROW &&
                                static_cast<uint64_t>(sqlite3_column_int64(at, 0)) == *last_id;
    sqlite3_finalize(at);
    if (saved->valid() && saved->rows() == *rows && same_keyframes) saved_rows = *rows;
  }

  const auto scan = [&](sqlite3_stmt* statement, bool from_file) {
    int status;
    while ((status = sqlite3_step(statement)) == SQLITE_ROW) {
      KeyframeSummary summary;
      summary.id = static_cast<uint64_t>(sqlite3_column_int64(statement, 0));
      summary.session = static_cast<uint32_t>(sqlite3_column_int64(statement, 1));
      summary.stamp = sqlite3_column_double(statement, 2);
      const uint8_t* vector = from_file
                                  ? saved->next()
                                  : static_cast<const uint8_t*>(sqlite3_column_blob(statement, 4));
      try {
        database_payload::decodeMotion(
            static_cast<const uint8_t*>(sqlite3_column_blob(statement, 3)),
            static_cast<size_t>(sqlite3_column_bytes(statement, 3)), &summary);
        if (vector == nullptr ||
            (!from_file && static_cast<size_t>(sqlite3_column_bytes(statement, 4)) != row_bytes)) {
          throw database_payload::FormatError("its global vector cannot be read");
        }
      } catch (const std::exception& error) {
        sqlite3_finalize(statement);
        throw storeError(path_,
                         "keyframe " + std::to_string(summary.id) + " is damaged: " + error.what());
      }
      visit(summary, vector, row_bytes);
    }
    sqlite3_finalize(statement);
    if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
  };
  if (saved_rows > 0) {
    sqlite3_stmt* head =
        c.prepare("SELECT id, session, stamp, motion FROM keyframes ORDER BY id LIMIT ?");
    sqlite3_bind_int64(head, 1, static_cast<sqlite3_int64>(saved_rows));
    scan(head, true);
  }
  sqlite3_stmt* rest = c.prepare(
      "SELECT id, session, stamp, motion, vector FROM keyframes WHERE id > ? ORDER BY id");
  sqlite3_bind_int64(rest, 1, saved_rows > 0 ? static_cast<sqlite3_int64>(*last_id) : -1);
  scan(rest, false);
}

std::string KeyframeStore::vectorsPath() const { return path_ + "-vectors"; }

std::string KeyframeStore::graphPath() const { return path_ + "-graph"; }

void KeyframeStore::saveGraph(const std::string& graph_identity, const ApproximateIndex& graph) {
  const std::string file = graphPath();
  graph.save(file);
  const std::optional<uint32_t> checksum = fileChecksum(file);
  if (!checksum) throw storeError(path_, "the search graph " + file + " cannot be read back");
  Connection& c = *connection_;
  std::optional<uint64_t> last_id;
  if (graph.size() > 0) {
    sqlite3_stmt* at = c.prepare("SELECT id FROM keyframes ORDER BY id LIMIT 1 OFFSET ?");
    sqlite3_bind_int64(at, 1, static_cast<sqlite3_int64>(graph.size() - 1));
    if (sqlite3_step(at) == SQLITE_ROW) last_id = sqlite3_column_int64(at, 0);
    sqlite3_finalize(at);
  }
  uint32_t vectors_checksum = 0;
  if (last_id) vectors_checksum = vector_file::write(vectorsPath(), *graph.vectors(), graph.size());
  c.execute("BEGIN IMMEDIATE", "the search graph not recorded");
  try {
    c.setMeta("graph_identity", graph_identity);
    c.setMeta("graph_keyframes", std::to_string(graph.size()));
    c.setMeta("graph_checksum", std::to_string(*checksum));
    c.setMeta("vectors_rows", last_id ? std::to_string(graph.size()) : "0");
    c.setMeta("vectors_checksum", std::to_string(vectors_checksum));
    c.setMeta("vectors_last_id", last_id ? std::to_string(*last_id) : "0");
  } catch (...) {
    sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  c.execute("COMMIT", "the search graph not recorded");
}

std::unique_ptr<ApproximateIndex> KeyframeStore::loadGraph(const std::string& graph_identity,
                                                           const QuantizedVectors* vectors,
                                                           int neighbors) const {
  Connection& c = *connection_;
  if (c.meta("graph_identity").value_or("") != graph_identity) return nullptr;
  const std::string file = graphPath();
  const std::optional<uint32_t> checksum = fileChecksum(file);
  if (!checksum || c.meta("graph_checksum").value_or("") != std::to_string(*checksum)) {
    return nullptr;  // Written by another map at this path, or damaged: built again.
  }
  try {
    return ApproximateIndex::load(file, vectors, neighbors);
  } catch (const std::runtime_error&) {
    return nullptr;
  }
}

}  // namespace landmark_loop_closure
