// What a map keeps beside it for search: its rows file (the only copy of each keyframe's 8-bit
// row, written as keyframes are committed), and the graph and summaries saved at a clean shutdown.
// Each is used only when it is this map's own; rows are mapped in place rather than copied; a rows
// file that is damaged, missing or another map's is refused by name (its sealed part by a check
// that may run while search does); rows a power cut lost are repaired away.
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/crc32c.h"
#include "database/vector_file.h"
#include "keyframe_fixtures.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

IndexOptions graphOptions() {
  IndexOptions graph;
  graph.type = "approximate";
  graph.neighbors = 8;
  return graph;
}

class KeyframeStoreTest : public MapFolderTest {
 protected:
  // Keyframes first..last of `session` committed to the map and added to search, as a node does.
  static void addBoth(KeyframeStore* store, KeyframeDatabase* database, uint64_t first,
                      uint64_t last, uint32_t session) {
    for (uint64_t id = first; id <= last; ++id) {
      store->add(makeKeyframe(id, session));
      database->add(makeKeyframe(id, session));
    }
  }

  // A map at `path` of keyframes 1..last of `session`, shut down cleanly; its path.
  static std::string sealMap(const std::string& path, uint64_t last, uint32_t session) {
    auto store = KeyframeStore::open(path, kIdentity, kDimension);
    KeyframeDatabase database(kDimension, graphOptions());
    addBoth(store.get(), &database, 1, last, session);
    store->saveGraph("hnsw M=8", database);
    return path;
  }

  // The map at path_: keyframes 1-5 sealed by a clean shutdown, then 6..last committed after the
  // seal (session 1), as a run killed before its next clean stop leaves them.
  void sealThenCommit(uint64_t last) {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    KeyframeDatabase database(kDimension, graphOptions());
    addBoth(store.get(), &database, 1, 5, 0);
    store->saveGraph("hnsw M=8", database);
    for (uint64_t id = 6; id <= last; ++id) store->add(makeKeyframe(id, 1));
  }

  void execute(const std::string& sql) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sql;
    sqlite3_close(db);
  }
};

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

ino_t inodeOf(const std::string& path) {
  struct stat status {};
  ::stat(path.c_str(), &status);
  return status.st_ino;
}

// What `action` threw as std::runtime_error; "" when it did not throw.
std::string failureOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::runtime_error& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST(QuantizedVectorsAdopt, RowsTakenInPlaceReadAndGrowAsCopiedOnes) {
  constexpr size_t kRows = 2500;  // Two whole chunks of 1024 rows, then part of a third.
  QuantizedVectors copied(kDimension);
  std::vector<uint8_t> block;
  for (size_t i = 0; i < kRows; ++i) {
    const std::vector<float> vector = makeKeyframe(i, 0).descriptor.global;
    const std::vector<uint8_t> row = QuantizedVectors::encode(vector);
    block.insert(block.end(), row.begin(), row.end());
    copied.append(vector.data());
  }
  auto owner = std::make_shared<std::vector<uint8_t>>(block);
  QuantizedVectors adopted(kDimension);
  adopted.adopt(owner, owner->data(), kRows);
  for (size_t i = kRows; i < kRows + 600; ++i) {
    const std::vector<float> vector = makeKeyframe(i, 0).descriptor.global;
    copied.append(vector.data());
    adopted.append(vector.data());
  }
  ASSERT_EQ(adopted.size(), copied.size());
  for (size_t i = 0; i < adopted.size(); ++i) {
    ASSERT_EQ(0, std::memcmp(adopted.row(i), copied.row(i), copied.rowBytes())) << i;
  }
  EXPECT_EQ(adopted.row(0), owner->data()) << "whole chunks are used where they lie";
  EXPECT_EQ(adopted.row(2047), owner->data() + 2047 * adopted.rowBytes());
  EXPECT_NE(adopted.row(2048), owner->data() + 2048 * adopted.rowBytes())
      << "the part-filled last chunk is copied, so rows can be appended after it";
  EXPECT_GE(adopted.bytes(), adopted.size() * adopted.rowBytes());
  EXPECT_THROW(adopted.adopt(owner, owner->data(), 1), std::logic_error);
}

TEST_F(KeyframeStoreTest, ASavedSearchGraphIsGivenBackOnlyForItsSettingsAndItsOwnFile) {
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  for (uint64_t id = 0; id < 5; ++id) store->add(makeKeyframe(id, 0));
  const auto openDatabase = [&] {
    KeyframeDatabase database(kDimension, IndexOptions{});
    store->forEachSummary([&](const KeyframeSummary& summary, const uint8_t* row, size_t bytes) {
      database.addSummary(summary, row, bytes);
    });
    return database;
  };
  const KeyframeDatabase database = openDatabase();
  ASSERT_NE(database.graph(), nullptr);
  store->saveGraph("hnsw M=16", database);

  KeyframeDatabase reopened = openDatabase();
  auto graph = store->loadGraph("hnsw M=16", reopened.vectors(), 16);
  ASSERT_NE(graph, nullptr);
  EXPECT_EQ(graph->size(), 5u);
  EXPECT_EQ(store->loadGraph("hnsw M=32", reopened.vectors(), 16), nullptr) << "other settings";

  // After a crash the map holds keyframes the graph does not: it is given back and the
  // database links the rest in.
  store->add(makeKeyframe(5, 0));
  KeyframeDatabase grown = openDatabase();
  graph = store->loadGraph("hnsw M=16", grown.vectors(), 16);
  ASSERT_NE(graph, nullptr);
  grown.setIndex(IndexOptions{}, std::move(graph));
  EXPECT_EQ(grown.graph()->size(), 6u);

  // A graph file changed behind the map's back (another map's, or damaged) is not used.
  {
    std::ofstream append(store->graphPath(), std::ios::binary | std::ios::app);
    append << "x";
  }
  EXPECT_EQ(store->loadGraph("hnsw M=16", grown.vectors(), 16), nullptr);
}

TEST_F(KeyframeStoreTest, EveryCommittedKeyframeHasItsRowInTheRowsFileAndOpeningMapsThem) {
  const size_t entry_bytes = sizeof(float) + kDimension + 92;
  KeyframeDatabase database(kDimension, graphOptions());
  ino_t inode = 0;
  std::string sealed_part;
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    addBoth(store.get(), &database, 1, 5, 0);
    inode = inodeOf(store->vectorsPath());
    store->saveGraph("hnsw M=8", database);
    sealed_part = bytesOf(store->vectorsPath());
    EXPECT_EQ(sealed_part.size(), 16 + 5 * entry_bytes);
    // Then four more and a crash (no clean shutdown): their rows are in the file all the same.
    addBoth(store.get(), &database, 6, 9, 1);
  }
  const std::string file = bytesOf(path_ + "-vectors");
  EXPECT_EQ(inodeOf(path_ + "-vectors"), inode) << "appended to, never written anew";
  ASSERT_EQ(file.size(), 16 + 9 * entry_bytes);
  EXPECT_EQ(file.substr(0, sealed_part.size()), sealed_part);
  // The database keeps no second copy of a row: which entry is the keyframe's, and its checksum.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* row = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT * FROM keyframes WHERE id = 9", -1, &row, nullptr),
            SQLITE_OK);
  ASSERT_EQ(sqlite3_step(row), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_count(row), 6);
  EXPECT_EQ(std::string(sqlite3_column_name(row, 4)), "search_row");
  EXPECT_EQ(sqlite3_column_int64(row, 4), 8);
  sqlite3_finalize(row);
  sqlite3_close(db);

  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 9u);
  EXPECT_TRUE(store->repairs().empty());
  KeyframeDatabase reopened(kDimension);
  store->loadSearch(&reopened);
  ASSERT_EQ(reopened.size(), 9u);
  for (size_t i = 0; i < 9; ++i) {
    const KeyframeRecord expected = makeKeyframe(i + 1, i < 5 ? 0 : 1);
    EXPECT_EQ(reopened.summary(i).id, expected.id);
    EXPECT_EQ(reopened.summary(i).session, expected.session);
    EXPECT_EQ(reopened.summary(i).stamp, expected.stamp);
    EXPECT_TRUE(reopened.summary(i).pose.position.isApprox(expected.pose.position));
    EXPECT_EQ(reopened.summary(i).path.metres, expected.path.metres);
    EXPECT_EQ(QuantizedVectors::decode(reopened.vectors()->row(i), kDimension),
              QuantizedVectors::decode(database.vectors()->row(i), kDimension));
  }
  // A keyframe read whole takes its global vector from the rows file.
  const std::optional<KeyframeRecord> seventh = store->get(7);
  ASSERT_TRUE(seventh);
  EXPECT_EQ(seventh->descriptor.global,
            QuantizedVectors::decode(database.vectors()->row(6), kDimension));
  // And search grows past the mapped rows.
  store->add(makeKeyframe(10, 2));
  reopened.add(makeKeyframe(10, 2));
  EXPECT_EQ(reopened.size(), 10u);
}

TEST_F(KeyframeStoreTest, ADamagedMissingOrForeignRowsFileIsRefusedWithItsName) {
  sealMap(path_, 5, 0);
  const std::string rows = path_ + "-vectors";
  const std::string good = bytesOf(rows);
  {
    std::fstream damage(rows, std::ios::in | std::ios::out | std::ios::binary);
    damage.seekp(30);
    damage.put('\x55');
  }
  // Opening looks at the sealed part's end only; the check finds the damage, in the tools at
  // open, in a node on its own thread while search runs.
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->integrityCheck(), KeyframeStore::MapCheck::kPending);
    store->startIntegrityCheck();
    EXPECT_EQ(store->awaitIntegrityCheck(), KeyframeStore::MapCheck::kFailed);
    EXPECT_NE(store->integrityProblem().find(rows + " are damaged"), std::string::npos)
        << store->integrityProblem();
    EXPECT_EQ(store->size(), 5u) << "nothing is removed for it";
  }
  std::string refused = failureOf([&] { KeyframeStore::openExisting(path_); });
  EXPECT_NE(refused.find(rows + " are damaged"), std::string::npos) << refused;
  refused = failureOf([&] { KeyframeStore::open(path_, kIdentity, kDimension)->checkIntegrity(); });
  EXPECT_NE(refused.find(rows + " are damaged"), std::string::npos) << refused;
  // Another map's rows file with the same keyframe ids: its content differs.
  fs::copy_file(sealMap((folder_ / "twin.db").string(), 5, 3) + "-vectors", rows,
                fs::copy_options::overwrite_existing);
  refused = failureOf([&] { KeyframeStore::openExisting(path_); });
  EXPECT_NE(refused.find(rows + " are damaged"), std::string::npos) << refused;
  // Another map's rows file (one keyframe fewer) is refused at open.
  fs::copy_file(sealMap((folder_ / "other.db").string(), 4, 0) + "-vectors", rows,
                fs::copy_options::overwrite_existing);
  refused = failureOf([&] { KeyframeStore::open(path_, kIdentity, kDimension); });
  EXPECT_NE(refused.find(rows + " are damaged"), std::string::npos) << refused;
  fs::remove(rows);
  refused = failureOf([&] { KeyframeStore::openExisting(path_); });
  EXPECT_NE(refused.find(rows + " are missing"), std::string::npos) << refused;
  // Put back, the map opens whole.
  std::ofstream(rows, std::ios::binary) << good;
  const auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 5u);
  store->startIntegrityCheck();
  EXPECT_EQ(store->awaitIntegrityCheck(), KeyframeStore::MapCheck::kPassed);
  EXPECT_EQ(store->integrityProblem(), "");
}

TEST_F(KeyframeStoreTest, ACleanShutdownKeepsTheSummariesSoOpeningNeedNotReadTheRows) {
  const size_t entry_bytes = sizeof(float) + kDimension + 92;
  sealMap(path_, 5, 0);
  ASSERT_EQ(fs::file_size(path_ + "-summaries"), 16 + 8 + 5 * 92 + 4);
  const std::string rows = path_ + "-vectors";
  const std::string good_rows = bytesOf(rows);
  const auto sessionsLoaded = [&] {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    KeyframeDatabase reopened(kDimension);
    store->loadSearch(&reopened);
    std::vector<uint32_t> sessions;
    for (size_t i = 0; i < reopened.size(); ++i) sessions.push_back(reopened.summary(i).session);
    return sessions;
  };
  const std::vector<uint32_t> right(5, 0);
  // Keyframe 2's session changed in the rows file: search still gets the saved one, so the rows
  // were not read for it (and their check finds the change).
  {
    std::fstream damage(rows, std::ios::in | std::ios::out | std::ios::binary);
    damage.seekp(16 + entry_bytes + sizeof(float) + kDimension + 8);
    damage.put('\x07');
  }
  EXPECT_EQ(sessionsLoaded(), right);
  EXPECT_NE(failureOf([&] { KeyframeStore::openExisting(path_); }).find("damaged"),
            std::string::npos);
  std::ofstream(rows, std::ios::binary) << good_rows;
  // Damaged, or another map's: the rows file is read instead.
  const std::string saved = bytesOf(path_ + "-summaries");
  {
    std::fstream damage(path_ + "-summaries", std::ios::in | std::ios::out | std::ios::binary);
    damage.seekp(16 + 8 + 92 + 8);  // Keyframe 2's session.
    damage.put('\x07');
  }
  EXPECT_EQ(sessionsLoaded(), right);
  fs::copy_file(sealMap((folder_ / "twin.db").string(), 5, 3) + "-summaries", path_ + "-summaries",
                fs::copy_options::overwrite_existing);
  EXPECT_EQ(sessionsLoaded(), right);
  std::ofstream(path_ + "-summaries", std::ios::binary) << saved;
  EXPECT_EQ(sessionsLoaded(), right);
  fs::remove(path_ + "-summaries");
  EXPECT_EQ(sessionsLoaded(), right);
}

TEST_F(KeyframeStoreTest, RowsLostAfterTheSealAreRepairedAndAnUncommittedEntryIsCut) {
  const size_t entry_bytes = sizeof(float) + kDimension + 92;
  sealThenCommit(8);
  // A keyframe whose commit never came left its entry past the map's keyframes.
  {
    std::ofstream append(path_ + "-vectors", std::ios::binary | std::ios::app);
    append << std::string(entry_bytes, 'x');
  }
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->size(), 8u);
    EXPECT_TRUE(store->repairs().empty());
    EXPECT_EQ(fs::file_size(path_ + "-vectors"), 16 + 8 * entry_bytes) << "the extra entry is cut";
  }
  // A power cut took the file's last pages but the database kept keyframes 7 and 8: they cannot
  // be searched, so they leave the map, which says so and takes new keyframes after keyframe 6.
  fs::resize_file(path_ + "-vectors", 16 + 6 * entry_bytes + 100);
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->size(), 6u);
    ASSERT_EQ(store->repairs().size(), 1u);
    EXPECT_NE(store->repairs()[0].find("2 keyframes from id 7"), std::string::npos)
        << store->repairs()[0];
    EXPECT_FALSE(store->get(7));
    store->add(makeKeyframe(7, 2));
  }
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 7u);
  EXPECT_TRUE(store->repairs().empty());
  store.reset();
  // A map never shut down cleanly whose rows file was emptied: refused, nothing removed.
  const std::string unsealed = (folder_ / "unsealed.db").string();
  { KeyframeStore::open(unsealed, kIdentity, kDimension)->add(makeKeyframe(1, 0)); }
  fs::resize_file(unsealed + "-vectors", 16);
  const std::string refused =
      failureOf([&] { KeyframeStore::open(unsealed, kIdentity, kDimension); });
  EXPECT_NE(refused.find("no keyframe's row matches"), std::string::npos) << refused;
  fs::resize_file(unsealed + "-vectors", 0);
  EXPECT_NE(
      failureOf([&] { KeyframeStore::open(unsealed, kIdentity, kDimension); }).find("damaged"),
      std::string::npos);
  store = KeyframeStore::open(path_, kIdentity, kDimension);
  KeyframeDatabase reopened(kDimension);
  store->loadSearch(&reopened);
  EXPECT_EQ(reopened.summary(6).session, 2u);
}

TEST_F(KeyframeStoreTest, ARowDamagedBeforeIntactOnesIsDamageNotAPowerCut) {
  const size_t entry_bytes = sizeof(float) + kDimension + 92;
  sealThenCommit(9);
  // Bytes flipped inside keyframe 7's row (entry 6); keyframes 8 and 9's rows are intact.
  {
    std::fstream damage(path_ + "-vectors", std::ios::in | std::ios::out | std::ios::binary);
    damage.seekp(static_cast<std::streamoff>(16 + 6 * entry_bytes + 10));
    damage.write("\xff\xfe\xfd\xfc", 4);
  }
  const std::string before = bytesOf(path_ + "-vectors");
  const std::string keyframes_before = bytesOf(path_);
  const std::string refused = failureOf([&] { KeyframeStore::open(path_, kIdentity, kDimension); });
  EXPECT_NE(refused.find("keyframe 7's search row does not match it, yet keyframe 8's"),
            std::string::npos)
      << refused;
  EXPECT_NE(refused.find("damaged"), std::string::npos) << refused;
  // Nothing was repaired away or cut: every keyframe and row is still there, and the tools that
  // only read a map report the same.
  EXPECT_EQ(bytesOf(path_ + "-vectors"), before);
  EXPECT_EQ(bytesOf(path_), keyframes_before);
  EXPECT_NE(failureOf([&] { KeyframeStore::openExisting(path_); }).find("yet keyframe 8's"),
            std::string::npos);
}

TEST_F(KeyframeStoreTest, SearchHoldingAKeyframeTheMapCouldNotTakeIsNotSaved) {
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  KeyframeDatabase database(kDimension, graphOptions());
  addBoth(store.get(), &database, 1, 5, 0);
  store->saveGraph("hnsw M=8", database);
  const std::string saved = bytesOf(store->vectorsPath());
  database.addUnstored(makeKeyframe(6, 0));  // The disk was full when it came.
  const std::string refused = failureOf([&] { store->saveGraph("hnsw M=8", database); });
  EXPECT_NE(refused.find("not saved"), std::string::npos)
      << "rows that do not line up with the map's keyframes were saved: " << refused;
  EXPECT_EQ(bytesOf(store->vectorsPath()), saved);
  KeyframeDatabase reopened(kDimension);
  store->loadSearch(&reopened);
  EXPECT_EQ(reopened.size(), 5u);
}

TEST_F(KeyframeStoreTest, OpeningRemovesWhatAnInterruptedSaveLeftAndSaysSo) {
  KeyframeStore::open(path_, kIdentity, kDimension)->add(makeKeyframe(1, 0));
  for (const std::string& leftover : {path_ + "-graph.tmp", path_ + "-vectors.tmp"}) {
    std::ofstream(leftover) << "half a file";
  }
  // Tools that only read a map leave them alone.
  KeyframeStore::openExisting(path_);
  EXPECT_TRUE(fs::exists(path_ + "-graph.tmp"));
  const auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->leftoversRemoved(),
            (std::vector<std::string>{path_ + "-graph.tmp", path_ + "-vectors.tmp"}));
  EXPECT_FALSE(fs::exists(path_ + "-graph.tmp"));
  EXPECT_FALSE(fs::exists(path_ + "-vectors.tmp"));
  EXPECT_EQ(store->size(), 1u);
}

TEST_F(KeyframeStoreTest, ALargeRowsFileIsCheckedInTwoStreamsToTheSameChecksum) {
  // Past 256 MB the check reads the file's halves at once; the result must be one pass's CRC.
  const int dimension = 4320;
  const size_t entry_bytes = vector_file::entryBytes(dimension);
  const uint64_t entries = (uint64_t{300} << 20) / entry_bytes;
  const std::string file = (folder_ / "large-vectors").string();
  std::vector<uint8_t> entry(entry_bytes);
  {
    vector_file::Writer writer(file, dimension);
    for (const uint64_t position : {uint64_t{0}, entries / 2 - 1, entries / 2, entries - 1}) {
      for (size_t i = 0; i < entry_bytes; ++i) entry[i] = static_cast<uint8_t>(position + i * 7);
      writer.write(position, entry.data());  // The rest is a hole: zeros, nothing on disk.
    }
  }
  const auto onePass = [&](const vector_file::Mapped& mapped) {
    return crc32c(0, mapped.entry(0) - vector_file::kHeaderBytes,
                  vector_file::kHeaderBytes + entries * entry_bytes);
  };
  uint32_t before = 0;
  {
    const auto mapped = vector_file::Mapped::open(file, dimension, entries);
    ASSERT_NE(mapped, nullptr);
    before = mapped->checksum(entries);
    EXPECT_EQ(before, onePass(*mapped));
  }
  {
    vector_file::Writer writer(file, dimension);
    entry.assign(entry_bytes, 1);
    writer.write(entries - 2, entry.data());  // A change in the second half.
  }
  const auto mapped = vector_file::Mapped::open(file, dimension, entries);
  ASSERT_NE(mapped, nullptr);
  EXPECT_NE(mapped->checksum(entries), before);
  EXPECT_EQ(mapped->checksum(entries), onePass(*mapped));
  EXPECT_EQ(mapped->checksum(3), crc32c(0, mapped->entry(0) - vector_file::kHeaderBytes,
                                        vector_file::kHeaderBytes + 3 * entry_bytes));
}
