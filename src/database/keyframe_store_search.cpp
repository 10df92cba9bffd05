// What search reads from a map: every keyframe's summary and 8-bit row at open (the rows saved
// beside the map mapped in place when they are this map's), and the search graph and rows saved at
// a clean shutdown.
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

}  // namespace

std::shared_ptr<const vector_file::Mapped> KeyframeStore::savedRows() const {
  Connection& c = *connection_;
  vector_file::Seal seal;
  seal.rows = c.metaNumber("vectors_rows").value_or(0);
  seal.rows_checksum = static_cast<uint32_t>(c.metaNumber("vectors_checksum").value_or(0));
  seal.summaries_checksum =
      static_cast<uint32_t>(c.metaNumber("vectors_summaries_checksum").value_or(0));
  const std::optional<uint64_t> last_id = c.metaNumber("vectors_last_id");
  if (!last_id || seal.rows == 0 || seal.rows > c.count) return nullptr;
  auto saved = vector_file::Mapped::open(vectorsPath(), seal, global_dimension_);
  try {
    if (saved && saved->summary(saved->rows() - 1).id == *last_id) return saved;
  } catch (const std::exception&) {
  }
  return nullptr;  // Another map's, damaged, or left half-written by a crash: not used.
}

void KeyframeStore::readSummaries(
    const std::function<void(const std::shared_ptr<const vector_file::Mapped>&)>& saved_rows,
    const std::function<void(const KeyframeSummary&, const uint8_t*, size_t)>& visit) const {
  Connection& c = *connection_;
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(global_dimension_);
  // The rows saved beside the map at the last clean shutdown, when they are this map's: mapped;
  // the keyframes committed after them (a crash) come from their database rows.
  const std::shared_ptr<const vector_file::Mapped> saved = savedRows();
  std::optional<uint64_t> last_saved;
  if (saved) {
    try {
      saved_rows(saved);
    } catch (const database_payload::FormatError& error) {
      throw storeError(path_, std::string("the saved search rows are damaged: ") + error.what());
    }
    last_saved = saved->summary(saved->rows() - 1).id;
  }
  sqlite3_stmt* rest = c.prepare(
      "SELECT id, session, stamp, motion, vector FROM keyframes WHERE id > ? ORDER BY id");
  sqlite3_bind_int64(rest, 1, last_saved ? static_cast<sqlite3_int64>(*last_saved) : -1);
  int status;
  while ((status = sqlite3_step(rest)) == SQLITE_ROW) {
    KeyframeSummary summary;
    summary.id = static_cast<uint64_t>(sqlite3_column_int64(rest, 0));
    summary.session = static_cast<uint32_t>(sqlite3_column_int64(rest, 1));
    summary.stamp = sqlite3_column_double(rest, 2);
    const auto* vector = static_cast<const uint8_t*>(sqlite3_column_blob(rest, 4));
    try {
      database_payload::decodeMotion(static_cast<const uint8_t*>(sqlite3_column_blob(rest, 3)),
                                     static_cast<size_t>(sqlite3_column_bytes(rest, 3)), &summary);
      if (vector == nullptr || static_cast<size_t>(sqlite3_column_bytes(rest, 4)) != row_bytes) {
        throw database_payload::FormatError("its global vector cannot be read");
      }
    } catch (const std::exception& error) {
      sqlite3_finalize(rest);
      throw storeError(path_,
                       "keyframe " + std::to_string(summary.id) + " is damaged: " + error.what());
    }
    visit(summary, vector, row_bytes);
  }
  sqlite3_finalize(rest);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
}

void KeyframeStore::forEachSummary(
    const std::function<void(const KeyframeSummary&, const uint8_t* vector_row, size_t row_bytes)>&
        visit) const {
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(global_dimension_);
  readSummaries(
      [&](const std::shared_ptr<const vector_file::Mapped>& saved) {
        for (size_t row = 0; row < saved->rows(); ++row) {
          visit(saved->summary(row), saved->firstRow() + row * row_bytes, row_bytes);
        }
      },
      visit);
}

void KeyframeStore::loadSearch(KeyframeDatabase* database) const {
  readSummaries(
      [&](const std::shared_ptr<const vector_file::Mapped>& saved) {
        database->addSaved(saved, saved->firstRow(), saved->rows(),
                           [&saved](size_t row) { return saved->summary(row); });
      },
      [&](const KeyframeSummary& summary, const uint8_t* row, size_t bytes) {
        database->addSummary(summary, row, bytes);
      });
}

std::string KeyframeStore::vectorsPath() const { return path_ + "-vectors"; }

std::string KeyframeStore::graphPath() const { return path_ + "-graph"; }

void KeyframeStore::saveGraph(const std::string& graph_identity, const KeyframeDatabase& database) {
  const ApproximateIndex* graph = database.graph();
  if (graph == nullptr) return;
  Connection& c = *connection_;
  // Rows and graph are valid only over the map's own keyframes in order; a keyframe the map could
  // not take (a full disk) would shift them. Not saved then: the next open builds them again.
  const size_t rows = graph->size();
  if (rows != c.count || rows != database.size() ||
      (rows > 0 && database.summary(rows - 1).id != c.last_id)) {
    throw storeError(path_,
                     "the search graph is not saved: the map lacks keyframes that search "
                     "holds (the disk was full); it is built again at the next open");
  }
  const std::string file = graphPath();
  graph->save(file);
  const std::optional<uint32_t> checksum = fileChecksum(file);
  if (!checksum) throw storeError(path_, "the search graph " + file + " cannot be read back");

  // The rows saved last time are kept and the new ones appended; while the file changes, the map
  // says there are none, so a crash in between leaves a file that is not used, never a wrong one.
  vector_file::Seal earlier;
  earlier.rows = c.metaNumber("vectors_rows").value_or(0);
  earlier.rows_checksum = static_cast<uint32_t>(c.metaNumber("vectors_checksum").value_or(0));
  earlier.summaries_checksum =
      static_cast<uint32_t>(c.metaNumber("vectors_summaries_checksum").value_or(0));
  if (earlier.rows > 0) c.setMeta("vectors_rows", "0");
  vector_file::Seal seal;
  if (rows > 0) {
    seal = vector_file::write(
        vectorsPath(), *database.vectors(), rows,
        [&database](size_t row) -> const KeyframeSummary& { return database.summary(row); },
        earlier.rows > 0 ? &earlier : nullptr);
  }
  c.execute("BEGIN IMMEDIATE", "the search graph not recorded");
  try {
    c.setMeta("graph_identity", graph_identity);
    c.setMeta("graph_keyframes", std::to_string(rows));
    c.setMeta("graph_checksum", std::to_string(*checksum));
    c.setMeta("vectors_rows", std::to_string(seal.rows));
    c.setMeta("vectors_checksum", std::to_string(seal.rows_checksum));
    c.setMeta("vectors_summaries_checksum", std::to_string(seal.summaries_checksum));
    c.setMeta("vectors_last_id", rows > 0 ? std::to_string(database.summary(rows - 1).id) : "0");
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
