// What a map keeps beside it for search: the graph and the 8-bit rows saved at a clean shutdown.
// Both are used only when they are this map's own; rows are mapped in place rather than copied,
// later saves append only the new rows, and a crash in the middle of a save leaves files that are
// not used rather than wrong ones.
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

#include "keyframe_fixtures.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

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

IndexOptions graphOptions() {
  IndexOptions graph;
  graph.type = "approximate";
  graph.neighbors = 8;
  return graph;
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

TEST_F(KeyframeStoreTest, SavedSearchRowsAreReadBackOnlyWhenTheyAreThisMapsAndCrashesAddTheRest) {
  std::vector<std::vector<uint8_t>> expected;
  const auto rowsOf = [](const KeyframeStore& store) {
    std::vector<std::vector<uint8_t>> rows;
    std::vector<uint64_t> ids;
    store.forEachSummary([&](const KeyframeSummary& summary, const uint8_t* row, size_t bytes) {
      rows.emplace_back(row, row + bytes);
      ids.push_back(summary.id);
    });
    return std::make_pair(rows, ids);
  };
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    IndexOptions graph;
    graph.type = "approximate";
    KeyframeDatabase database(kDimension, graph);
    addBoth(store.get(), &database, 1, 6, 0);
    expected = rowsOf(*store).first;  // From the database rows: nothing saved yet.
    store->saveGraph("hnsw M=8", database);
    EXPECT_TRUE(fs::exists(store->vectorsPath()));
    // Then two more before a crash: not in the saved rows.
    for (uint64_t id = 7; id <= 8; ++id) {
      store->add(makeKeyframe(id, 1));
      expected.push_back(QuantizedVectors::encode(makeKeyframe(id, 1).descriptor.global));
    }
  }
  // Keyframe 3's row in the map is spoilt behind the store's back: read from the saved rows, it
  // does not matter.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE keyframes SET vector = x'00' WHERE id = 3", nullptr, nullptr,
                         nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  auto [rows, ids] = rowsOf(*store);
  EXPECT_EQ(ids, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(rows, expected);
  // A damaged rows file is not used: the map's rows are read, and keyframe 3's is refused.
  {
    std::fstream damage(store->vectorsPath(), std::ios::in | std::ios::out | std::ios::binary);
    damage.seekp(30);
    damage.put('\x55');
  }
  const std::string refused = failureOf([&] { rowsOf(*store); });
  EXPECT_NE(refused.find("keyframe 3 is damaged"), std::string::npos)
      << "the damaged rows file was used: " << refused;
}

TEST_F(KeyframeStoreTest, ALaterSaveAppendsOnlyTheNewRowsAndOpeningMapsThem) {
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  KeyframeDatabase database(kDimension, graphOptions());
  addBoth(store.get(), &database, 1, 5, 0);
  store->saveGraph("hnsw M=8", database);
  const std::string first = bytesOf(store->vectorsPath());
  const ino_t inode = inodeOf(store->vectorsPath());
  addBoth(store.get(), &database, 6, 9, 1);
  store->saveGraph("hnsw M=8", database);
  const std::string second = bytesOf(store->vectorsPath());
  EXPECT_EQ(inodeOf(store->vectorsPath()), inode) << "appended to, not written anew";
  const size_t rows_part = 16 + 5 * (sizeof(float) + kDimension);
  ASSERT_GT(second.size(), first.size());
  EXPECT_EQ(second.substr(0, rows_part), first.substr(0, rows_part))
      << "the rows saved before are left as they were";
  store.reset();

  // Keyframe 3's row in the map is spoilt: opened from the saved rows it does not matter, and the
  // summaries come from there too.
  execute("UPDATE keyframes SET vector = x'00' WHERE id = 3");
  store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 9u);
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
}

TEST_F(KeyframeStoreTest, ASaveCutShortLeavesRowsThatAreNotUsedAndTheCountRight) {
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    KeyframeDatabase database(kDimension, graphOptions());
    addBoth(store.get(), &database, 1, 5, 0);
    store->saveGraph("hnsw M=8", database);
    // Then three more and a crash: the map counts them after the saved ones.
    for (uint64_t id = 6; id <= 8; ++id) store->add(makeKeyframe(id, 1));
  }
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->size(), 8u);
    store->add(makeKeyframe(9, 2));
    EXPECT_THROW(store->add(makeKeyframe(8, 2)), std::runtime_error);
  }
  // A save that was appending when the process died: the map says no rows are saved, and the file
  // holds more than it said before. The map's rows are read (keyframe 3's is spoilt to show it).
  execute("UPDATE meta SET value = '0' WHERE key = 'vectors_rows'");
  execute("UPDATE keyframes SET vector = x'00' WHERE id = 3");
  {
    std::ofstream append(path_ + "-vectors", std::ios::binary | std::ios::app);
    append << std::string(40, 'x');
  }
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 9u);
  KeyframeDatabase reopened(kDimension);
  const std::string refused = failureOf([&] { store->loadSearch(&reopened); });
  EXPECT_NE(refused.find("keyframe 3 is damaged"), std::string::npos)
      << "the half-written rows file was used: " << refused;
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
