// What search reads from a map: the search rows file, checked at open and mapped in place, and
// the search graph saved at a clean shutdown.
#include "landmark_loop_closure/database/keyframe_store.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/checksummed_file.h"
#include "common/crc32c.h"
#include "common/little_endian.h"
#include "database/keyframe_codec.h"
#include "database/store_connection.h"
#include "database/vector_file.h"

namespace landmark_loop_closure {

namespace {

constexpr char kSummariesMagic[8] = {'L', 'L', 'C', 'S', 'U', 'M', 'S', '\n'};
constexpr uint32_t kSummariesVersion = 1;

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

// The first `entries` entries of a map's rows file, mapped; throws naming the map when they
// cannot be.
std::shared_ptr<const vector_file::Mapped> mapRows(const std::string& map_path,
                                                   const std::string& rows_path, int dimension,
                                                   uint64_t entries) {
  auto mapped = vector_file::Mapped::open(rows_path, dimension, entries);
  if (!mapped) throw storeError(map_path, "its search rows " + rows_path + " cannot be read");
  return mapped;
}

}  // namespace

void KeyframeStore::openRows() {
  Connection& c = *connection_;
  const std::string file = vectorsPath();
  std::error_code error;
  if (c.count == 0) {
    std::filesystem::remove(file, error);  // An earlier map's, left at this path.
  } else if (!std::filesystem::exists(file, error)) {
    throw storeError(path_, "its search rows " + file +
                                " are missing (a map is its file and the -vectors file beside it: "
                                "copy and move them together)");
  }
  try {
    rows_ = std::make_unique<vector_file::Writer>(file, global_dimension_);
  } catch (const std::exception& open_error) {
    throw storeError(path_, open_error.what());
  }
  const uint64_t on_disk = rows_->entriesOnDisk();
  const auto mapped = mapRows(path_, file, global_dimension_, std::min<uint64_t>(c.count, on_disk));
  const auto damaged = [&](const std::string& what) {
    return storeError(path_,
                      "its search rows " + file + " are damaged or another map's (" + what + ")");
  };
  // The entries sealed at the last clean shutdown: here only that they are there and end with the
  // right keyframe; their checksum is part of the integrity check.
  const uint64_t sealed = c.metaNumber("vectors_rows").value_or(0);
  uint64_t checked = 0;
  uint32_t crc = mapped->checksum(0);  // The header's.
  std::optional<uint64_t> last_checked_id;
  if (sealed > 0) {
    const std::optional<uint64_t> sealed_last = c.metaNumber("vectors_last_id");
    const std::optional<uint64_t> sealed_checksum = c.metaNumber("vectors_checksum");
    if (sealed > mapped->entries() || !sealed_last) throw damaged("shorter than its seal");
    bool last_matches = false;
    try {
      last_matches = sealed_checksum && mapped->summary(sealed - 1).id == *sealed_last;
    } catch (const std::exception&) {
    }
    if (!last_matches)
      throw damaged("its last sealed entry is not keyframe " + std::to_string(*sealed_last) + "'s");
    crc = static_cast<uint32_t>(*sealed_checksum);
    if (check_) {
      check_->rows = mapped;
      check_->entries = sealed;
      check_->expected = crc;
      check_->rows_damaged = damaged("checksum").what();
    }
    checked = sealed;
    last_checked_id = sealed_last;
  }
  // The keyframes committed after it (no clean shutdown since): each entry against its keyframe.
  sqlite3_stmt* later =
      c.prepare("SELECT id, search_row, row_checksum FROM keyframes WHERE id > ? ORDER BY id");
  sqlite3_bind_int64(later, 1, last_checked_id ? static_cast<sqlite3_int64>(*last_checked_id) : -1);
  std::optional<uint64_t> first_lost;
  int status;
  while ((status = sqlite3_step(later)) == SQLITE_ROW) {
    const auto id = static_cast<uint64_t>(sqlite3_column_int64(later, 0));
    const auto position = static_cast<uint64_t>(sqlite3_column_int64(later, 1));
    const auto checksum = static_cast<uint32_t>(sqlite3_column_int64(later, 2));
    const size_t bytes = mapped->entryBytes();
    const bool matches = position < mapped->entries() &&
                         crc32c(0, mapped->entry(position), bytes) == checksum &&
                         mapped->summary(position).id == id;
    if (first_lost) {
      // A power cut loses the file's last pages: a row that matches after a lost one means the
      // file was damaged in its middle, and repairing would delete intact keyframes.
      if (matches) {
        sqlite3_finalize(later);
        throw damaged("keyframe " + std::to_string(*first_lost) +
                      "'s search row does not match it, yet keyframe " + std::to_string(id) +
                      "'s later one does (damaged, not cut short by a power cut)");
      }
      continue;
    }
    if (position != checked) {
      sqlite3_finalize(later);
      throw damaged("keyframe " + std::to_string(id) + " points at entry " +
                    std::to_string(position) + ", not " + std::to_string(checked));
    }
    if (!matches) {
      first_lost = id;
      continue;
    }
    crc = crc32c(crc, mapped->entry(position), bytes);
    ++checked;
  }
  sqlite3_finalize(later);
  if (status != SQLITE_DONE) c.fail("cannot read the keyframes");
  // Not one row matching is no power cut's doing (another map's file, or an emptied one): refused,
  // the keyframes left as they are.
  if (first_lost && checked == 0) throw damaged("no keyframe's row matches");
  if (first_lost) {
    // Rows are written before their keyframe commits, so only a power cut (the rows file's last
    // pages lost, the database's kept) gets here: those keyframes cannot be searched.
    const size_t lost = c.count - checked;
    c.execute("BEGIN IMMEDIATE", "cannot be repaired");
    std::vector<const char*> removals = {"DELETE FROM keyframes WHERE id >= ?",
                                         "DELETE FROM records WHERE id >= ?"};
    if (c.has_stamps) removals.push_back("DELETE FROM keyframe_stamps WHERE id >= ?");
    for (const char* sql : removals) {
      sqlite3_stmt* statement = c.prepare(sql);
      sqlite3_bind_int64(statement, 1, static_cast<sqlite3_int64>(*first_lost));
      const int removed = sqlite3_step(statement);
      sqlite3_finalize(statement);
      if (removed != SQLITE_DONE) {
        sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
        c.fail("cannot be repaired");
      }
    }
    c.execute("COMMIT", "cannot be repaired");
    repairs_.push_back(std::to_string(lost) + " keyframes from id " + std::to_string(*first_lost) +
                       " had lost their search rows (a power cut?) and were removed from the map");
    c.count = checked;
    c.last_id =
        checked > 0 ? std::optional<uint64_t>(mapped->summary(checked - 1).id) : std::nullopt;
  }
  // An entry past the map's keyframes was written for a keyframe whose commit never came.
  if (on_disk > c.count) rows_->truncate(c.count);
  entries_checksum_ = crc;
}

void KeyframeStore::forEachSummary(
    const std::function<void(const KeyframeSummary&, const uint8_t* vector_row, size_t row_bytes)>&
        visit) const {
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(global_dimension_);
  const auto mapped = mapRows(path_, vectorsPath(), global_dimension_, connection_->count);
  for (size_t index = 0; index < mapped->entries(); ++index) {
    KeyframeSummary summary;
    try {
      summary = mapped->summary(index);
    } catch (const std::exception& error) {
      throw storeError(path_,
                       "search row " + std::to_string(index) + " is damaged: " + error.what());
    }
    visit(summary, mapped->row(index), row_bytes);
  }
}

size_t KeyframeStore::rowStride() const { return vector_file::entryBytes(global_dimension_); }

std::optional<KeyframeSummary> KeyframeStore::lastSummary() const {
  if (connection_->count == 0) return std::nullopt;
  return entrySummary(connection_->count - 1);
}

KeyframeSummary KeyframeStore::entrySummary(size_t position) const {
  const std::vector<uint8_t> entry = rows_->read(position);
  const size_t row_bytes = sizeof(float) + static_cast<size_t>(global_dimension_);
  try {
    if (entry.size() < row_bytes + vector_file::kSummaryBytes) {
      throw std::runtime_error("it is shorter than the map");
    }
    return vector_file::decodeSummary(entry.data() + row_bytes);
  } catch (const std::exception& error) {
    throw storeError(path_,
                     "search row " + std::to_string(position) + " is damaged: " + error.what());
  }
}

void KeyframeStore::loadSearch(KeyframeDatabase* database, size_t keyframes) const {
  keyframes = std::min(keyframes, connection_->count);
  if (keyframes == 0) return;
  const auto mapped = mapRows(path_, vectorsPath(), global_dimension_, keyframes);
  // Summaries from the rows file would read all of it (each sits beside its 4 KB row): those
  // saved at the last clean shutdown are read instead, the others front to back.
  const std::vector<uint8_t> saved = savedSummaries();
  const size_t saved_count = std::min(saved.size() / vector_file::kSummaryBytes, keyframes);
  try {
    database->addSaved(
        mapped, mapped->row(0), mapped->entries(),
        [&](size_t row) {
          return row < saved_count
                     ? vector_file::decodeSummary(saved.data() + row * vector_file::kSummaryBytes)
                     : mapped->summary(row);
        },
        mapped->entryBytes());
    mapped->readAtRandom();  // Search reads rows here and there.
  } catch (const std::exception& error) {
    throw storeError(path_, std::string("its search rows are damaged: ") + error.what());
  }
}

std::optional<uint64_t> KeyframeStore::searchRowOf(uint64_t id) const {
  sqlite3_stmt* statement = connection_->prepare("SELECT search_row FROM keyframes WHERE id = ?");
  sqlite3_bind_int64(statement, 1, static_cast<sqlite3_int64>(id));
  std::optional<uint64_t> row;
  if (sqlite3_step(statement) == SQLITE_ROW) {
    row = static_cast<uint64_t>(sqlite3_column_int64(statement, 0));
  }
  sqlite3_finalize(statement);
  return row;
}

std::string KeyframeStore::vectorsPath() const { return path_ + "-vectors"; }

std::string KeyframeStore::graphPath() const { return path_ + "-graph"; }

size_t KeyframeStore::savedGraphKeyframes(const std::string& graph_identity) const {
  Connection& c = *connection_;
  std::error_code error;
  if (c.meta("graph_identity").value_or("") != graph_identity ||
      !std::filesystem::is_regular_file(graphPath(), error)) {
    return 0;
  }
  return static_cast<size_t>(c.metaNumber("graph_keyframes").value_or(0));
}

std::string KeyframeStore::summariesPath() const { return path_ + "-summaries"; }

std::optional<uint32_t> KeyframeStore::saveSummaries(const KeyframeDatabase& database, size_t count,
                                                     std::string* error) const {
  LittleEndianWriter writer;
  beginChecksummedFile(&writer, kSummariesMagic, kSummariesVersion);
  writer.u64(count);
  std::vector<uint8_t> encoded(vector_file::kSummaryBytes);
  uint32_t crc = 0;
  for (size_t i = 0; i < count; ++i) {
    vector_file::encodeSummary(database.summary(i), encoded.data());
    writer.bytes(encoded.data(), encoded.size());
    crc = crc32c(crc, encoded.data(), encoded.size());
  }
  *error = finishChecksummedFile(summariesPath(), &writer);
  if (!error->empty()) return std::nullopt;
  return crc;
}

std::vector<uint8_t> KeyframeStore::savedSummaries() const {
  Connection& c = *connection_;
  const std::optional<uint64_t> count = c.metaNumber("summaries_keyframes");
  const std::optional<uint64_t> checksum = c.metaNumber("summaries_checksum");
  if (!count || *count == 0 || *count > connection_->count || !checksum) return {};
  std::vector<uint8_t> body;
  if (!readChecksummedFile(summariesPath(), kSummariesMagic, kSummariesVersion, "summaries", &body)
           .empty() ||
      body.size() != 8 + *count * vector_file::kSummaryBytes) {
    return {};  // Missing, damaged, or a newer version's: the rows file is read instead.
  }
  body.erase(body.begin(), body.begin() + 8);
  // Written with this map's seal, and its last keyframe is the rows file's at that place.
  try {
    const size_t last = (*count - 1) * vector_file::kSummaryBytes;
    if (crc32c(0, body.data(), body.size()) != *checksum ||
        vector_file::decodeSummary(body.data() + last).id != entrySummary(*count - 1).id) {
      return {};
    }
  } catch (const std::exception&) {
    return {};
  }
  return body;
}

void KeyframeStore::saveGraph(const std::string& graph_identity, const KeyframeDatabase& database) {
  if (integrityCheck() == MapCheck::kFailed) {
    throw storeError(path_, "nothing saved beside a damaged map");
  }
  settleBeforeClose();
  Connection& c = *connection_;
  // The rows reach the disk before the seal that vouches for them.
  try {
    rows_->sync();
  } catch (const std::exception& error) {
    throw storeError(path_, error.what());
  }
  const ApproximateIndex* graph = database.graph();
  // The graph is valid over the map's first keyframes in order (those past the memory budget
  // follow them; the next open links them in); a keyframe the map could not take (a full disk)
  // would shift it. Not saved then: the next open builds it again.
  const size_t rows = database.size();
  const bool search_fits =
      rows <= c.count && (rows == 0 || searchRowOf(database.summary(rows - 1).id) == rows - 1);
  const bool graph_fits = graph != nullptr && graph->size() == rows && search_fits;
  std::optional<uint32_t> summaries_checksum;
  std::string summaries_error;  // Not saved: the next open reads the rows file instead.
  if (search_fits && rows > 0) summaries_checksum = saveSummaries(database, rows, &summaries_error);
  std::optional<uint32_t> graph_checksum;
  if (graph_fits) {
    const std::string file = graphPath();
    graph->save(file);
    graph_checksum = fileChecksum(file);
    if (!graph_checksum)
      throw storeError(path_, "the search graph " + file + " cannot be read back");
  }
  c.execute("BEGIN IMMEDIATE", "the search rows not sealed");
  try {
    c.setMeta("vectors_rows", std::to_string(c.count));
    c.setMeta("vectors_checksum", std::to_string(entries_checksum_));
    c.setMeta("vectors_last_id", c.last_id ? std::to_string(*c.last_id) : "0");
    if (summaries_checksum) {
      c.setMeta("summaries_keyframes", std::to_string(rows));
      c.setMeta("summaries_checksum", std::to_string(*summaries_checksum));
    }
    if (graph_checksum) {
      c.setMeta("graph_identity", graph_identity);
      c.setMeta("graph_keyframes", std::to_string(rows));
      c.setMeta("graph_checksum", std::to_string(*graph_checksum));
    }
  } catch (...) {
    sqlite3_exec(c.db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  c.execute("COMMIT", "the search rows not sealed");
  if (!summaries_error.empty()) {
    throw storeError(path_, "the summaries for a fast open are not saved (" + summaries_error +
                                "); the next open reads them from the search rows");
  }
  if (graph != nullptr && !graph_fits) {
    throw storeError(path_,
                     "the search graph is not saved: the map lacks keyframes that search "
                     "holds (the disk was full); it is built again at the next open");
  }
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
