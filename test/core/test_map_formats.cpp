// Maps of the store's earlier formats are named and converted once with every field; sessions
// are exported and robots' maps merged. Split from test_keyframe_store.cpp.
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "../../src/database/keyframe_codec.h"
#include "keyframe_fixtures.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/map_tools.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "old_map_file_writer.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

using KeyframeStoreTest = MapFolderTest;

// A map of an earlier store format at `path`: its `tables` (SQL) and the settings of `version`;
// nullptr when SQLite refuses.
sqlite3* earlierFormatMap(const std::string& path, const std::string& version,
                          const std::string& tables) {
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) return nullptr;
  const std::string setup = "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);" +
                            tables + "INSERT INTO meta VALUES ('format_version', '" + version +
                            "'), ('descriptor_identity', '" + std::string(kIdentity) +
                            "'), ('global_dimension', '" + std::to_string(kDimension) + "');";
  if (sqlite3_exec(db, setup.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return nullptr;
  }
  return db;
}

}  // namespace

TEST_F(KeyframeStoreTest, AMapOfTheEarlierFormatIsNamedWithItsConversion) {
  std::ofstream(path_, std::ios::binary) << "LLCKFDB\n" << std::string(64, '\0');
  EXPECT_TRUE(KeyframeStore::isOldMapFile(path_));
  EXPECT_NE(openRefusal(path_).find("lcd_db convert"), std::string::npos) << openRefusal(path_);
}

TEST_F(KeyframeStoreTest, MapsOfTheEarlierFormatConvertOnceWithEveryField) {
  std::vector<KeyframeRecord> keyframes;
  for (uint64_t id = 3; id < 13; ++id) keyframes.push_back(makeKeyframe(id, id < 8 ? 0 : 1));
  const std::string old_file = (folder_ / "old.lcdb").string();
  writeOldMapFile(keyframes, kIdentity, kDimension, old_file);

  EXPECT_EQ(convertMapFile(old_file, path_), 10u);
  const MapSummary summary = summariseMap(path_);
  EXPECT_EQ(summary.descriptor_identity, kIdentity);
  EXPECT_EQ(summary.global_dimension, kDimension);
  EXPECT_EQ(summary.keyframes_per_session, (std::map<uint32_t, size_t>{{0, 5}, {1, 5}}));
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  for (uint64_t id = 3; id < 13; ++id)
    expectSame(*store->get(id), asStored(makeKeyframe(id, id < 8 ? 0 : 1)));
  store.reset();
  EXPECT_THROW(convertMapFile(old_file, path_), std::runtime_error) << "never over a map";
  EXPECT_THROW(convertMapFile(path_, (folder_ / "again.db").string()), std::runtime_error)
      << "a map of the current format is not converted";
  EXPECT_FALSE(fs::exists(folder_ / "again.db"));
  EXPECT_FALSE(fs::exists(folder_ / "again.db.partial"));
}

TEST_F(KeyframeStoreTest, SessionsExportAndRobotsMapsMerge) {
  const std::string robot_a = (folder_ / "a.db").string();
  const std::string robot_b = (folder_ / "b.db").string();
  {
    auto a = KeyframeStore::open(robot_a, kIdentity, kDimension);
    for (uint64_t id = 0; id < 6; ++id) a->add(makeKeyframe(id, id < 3 ? 0 : 1));
    auto b = KeyframeStore::open(robot_b, kIdentity, kDimension);
    for (uint64_t id = 0; id < 4; ++id) b->add(makeKeyframe(id, 0));
  }
  const std::string session_1 = (folder_ / "session1.db").string();
  EXPECT_EQ(exportSession(robot_a, 1, session_1), 3u);
  EXPECT_EQ(summariseMap(session_1).keyframes_per_session, (std::map<uint32_t, size_t>{{1, 3}}));

  const std::string merged = (folder_ / "merged.db").string();
  std::vector<uint32_t> first_sessions;
  EXPECT_EQ(mergeMaps(merged, {robot_a, robot_b}, &first_sessions), 10u);
  EXPECT_EQ(first_sessions, (std::vector<uint32_t>{0, 2}));
  auto store = KeyframeStore::openExisting(merged);
  // Robot b's first keyframe: renumbered after robot a's six, its session after a's two.
  const std::optional<KeyframeRecord> moved = store->get(6);
  ASSERT_TRUE(moved);
  EXPECT_EQ(moved->session, 2u);
  EXPECT_EQ(moved->stamp, makeKeyframe(0, 0).stamp);
  EXPECT_EQ(moved->descriptor.global, asStored(makeKeyframe(0, 0)).descriptor.global);
  store.reset();

  const std::string other = (folder_ / "other.db").string();
  { KeyframeStore::open(other, "type=other", kDimension)->add(makeKeyframe(0, 0)); }
  try {
    mergeMaps((folder_ / "mixed.db").string(), {robot_a, other});
    FAIL() << "maps of other descriptors were merged";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("other descriptors"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(folder_ / "mixed.db"));
}

TEST_F(KeyframeStoreTest, AMapOfTheStoresFirstFormatIsRefusedAndConvertsOnce) {
  // Format 1 kept each keyframe whole in the earlier file's layout: the bytes a one-keyframe file
  // of that format holds between its keyframe's offset and the graph's (its record table).
  const std::string old_file = (folder_ / "one.lcdb").string();
  writeOldMapFile({makeKeyframe(4, 2)}, kIdentity, kDimension, old_file);
  std::ifstream in(old_file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto u64At = [&](size_t at) {
    uint64_t value = 0;
    for (int i = 7; i >= 0; --i) value = (value << 8) | static_cast<uint8_t>(bytes[at + i]);
    return value;
  };
  constexpr size_t kHeader = 28;
  const uint64_t first = u64At(bytes.size() - 24);
  const uint64_t graph = u64At(bytes.size() - 16);
  const std::string record = bytes.substr(kHeader + first, graph - first);

  sqlite3* db = earlierFormatMap(path_, "1",
                                 "CREATE TABLE keyframes (id INTEGER PRIMARY KEY, session INTEGER, "
                                 "stamp REAL, global BLOB, record BLOB);");
  ASSERT_NE(db, nullptr);
  sqlite3_stmt* insert = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO keyframes VALUES (4, 2, 0, x'00', ?)", -1, &insert, nullptr);
  sqlite3_bind_blob(insert, 1, record.data(), static_cast<int>(record.size()), SQLITE_STATIC);
  ASSERT_EQ(sqlite3_step(insert), SQLITE_DONE);
  sqlite3_finalize(insert);
  sqlite3_close(db);

  EXPECT_NE(openRefusal(path_).find("lcd_db convert"), std::string::npos) << openRefusal(path_);
  const std::string converted = (folder_ / "converted.db").string();
  EXPECT_EQ(convertMapFile(path_, converted), 1u);
  auto store = KeyframeStore::open(converted, kIdentity, kDimension);
  expectSame(*store->get(4), asStored(makeKeyframe(4, 2)));
}

TEST_F(KeyframeStoreTest, AMapOfTheStoresSecondFormatIsRefusedAndConvertsOnce) {
  // Format 2 kept each keyframe's 8-bit global row in the database, beside its summary.
  sqlite3* db = earlierFormatMap(
      path_, "2",
      "CREATE TABLE keyframes (id INTEGER PRIMARY KEY, session INTEGER NOT NULL, stamp REAL NOT "
      "NULL, motion BLOB NOT NULL, vector BLOB NOT NULL);"
      "CREATE TABLE records (id INTEGER PRIMARY KEY, record BLOB NOT NULL);");
  ASSERT_NE(db, nullptr);
  for (uint64_t id = 2; id <= 4; ++id) {
    const KeyframeRecord keyframe = makeKeyframe(id, id < 4 ? 0 : 1);
    const std::vector<uint8_t> motion = database_payload::encodeMotion(keyframe);
    const std::vector<uint8_t> vector = QuantizedVectors::encode(keyframe.descriptor.global);
    const std::vector<uint8_t> record = database_payload::encodeRecord(keyframe);
    sqlite3_stmt* insert = nullptr;
    sqlite3_prepare_v2(db, "INSERT INTO keyframes VALUES (?, ?, ?, ?, ?)", -1, &insert, nullptr);
    sqlite3_bind_int64(insert, 1, static_cast<sqlite3_int64>(id));
    sqlite3_bind_int64(insert, 2, keyframe.session);
    sqlite3_bind_double(insert, 3, keyframe.stamp);
    sqlite3_bind_blob(insert, 4, motion.data(), static_cast<int>(motion.size()), SQLITE_STATIC);
    sqlite3_bind_blob(insert, 5, vector.data(), static_cast<int>(vector.size()), SQLITE_STATIC);
    ASSERT_EQ(sqlite3_step(insert), SQLITE_DONE);
    sqlite3_finalize(insert);
    sqlite3_prepare_v2(db, "INSERT INTO records VALUES (?, ?)", -1, &insert, nullptr);
    sqlite3_bind_int64(insert, 1, static_cast<sqlite3_int64>(id));
    sqlite3_bind_blob(insert, 2, record.data(), static_cast<int>(record.size()), SQLITE_STATIC);
    ASSERT_EQ(sqlite3_step(insert), SQLITE_DONE);
    sqlite3_finalize(insert);
  }
  sqlite3_close(db);

  EXPECT_NE(openRefusal(path_).find("lcd_db convert"), std::string::npos) << openRefusal(path_);
  const std::string converted = (folder_ / "converted.db").string();
  EXPECT_EQ(convertMapFile(path_, converted), 3u);
  EXPECT_TRUE(fs::exists(converted + "-vectors"));
  EXPECT_FALSE(fs::exists(converted + ".partial-vectors"));
  auto store = KeyframeStore::open(converted, kIdentity, kDimension);
  for (uint64_t id = 2; id <= 4; ++id) {
    expectSame(*store->get(id), asStored(makeKeyframe(id, id < 4 ? 0 : 1)));
  }
}
