// The keyframe store: every field survives a commit and a reopen; a writer killed with SIGKILL at
// any moment loses no keyframe add() returned for and leaves a map that opens; foreign, newer,
// locked and non-regular files are refused with a reason.
#include <signal.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "../../src/database/keyframe_codec.h"
#include "keyframe_fixtures.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/map_tools.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

using KeyframeStoreTest = MapFolderTest;

TEST_F(KeyframeStoreTest, EveryFieldSurvivesAReopen) {
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    for (uint64_t id = 10; id < 20; ++id) store->add(makeKeyframe(id, id < 15 ? 0 : 1));
    EXPECT_EQ(store->size(), 10u);
  }
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), 10u);
  EXPECT_EQ(store->sessions(), (std::vector<uint32_t>{0, 1}));
  for (uint64_t id = 10; id < 20; ++id) {
    const std::optional<KeyframeRecord> keyframe = store->get(id);
    ASSERT_TRUE(keyframe) << id;
    expectSame(*keyframe, asStored(makeKeyframe(id, id < 15 ? 0 : 1)));
  }
  EXPECT_FALSE(store->get(9));
  std::vector<uint64_t> ids;
  store->forEachSummary([&ids](const KeyframeSummary& summary, const uint8_t* row, size_t bytes) {
    ids.push_back(summary.id);
    const KeyframeRecord expected = makeKeyframe(summary.id, 0);
    EXPECT_EQ(QuantizedVectors::decode(row, kDimension), asStored(expected).descriptor.global);
    EXPECT_EQ(bytes, 4u + kDimension);
    EXPECT_EQ(summary.stamp, expected.stamp);
    EXPECT_EQ(summary.pose.position, expected.pose.position);
    EXPECT_EQ(summary.path.metres, expected.path.metres);
  });
  EXPECT_EQ(ids.size(), 10u);
  EXPECT_EQ(ids.front(), 10u);
}

// Issue 67 point 6: a stamp in seconds as a double is about 0.2 us apart at today's times; a
// backend matching a loaded keyframe's stamp with its own messages needs the camera's exactly.
TEST_F(KeyframeStoreTest, StampsAreKeptToTheNanosecondAndEarlierMapsGainThemWithTheirNextWrite) {
  const int64_t exact = 1700000000123456789;  // Not a double's value: 1700000000.1234567165 is.
  ASSERT_NE(std::llround((exact * 1e-9) * 1e9), exact);
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    KeyframeRecord keyframe = makeKeyframe(1, 0);
    keyframe.stamp = exact * 1e-9;
    keyframe.stamp_ns = exact;
    store->add(keyframe);
    store->add(makeKeyframe(2, 0));  // No exact stamp given: its seconds, rounded.
  }
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->get(1)->stamp_ns, exact);
    EXPECT_EQ(store->get(2)->stamp_ns, std::llround(makeKeyframe(2, 0).stamp * 1e9));
    std::vector<int64_t> stamps;
    store->forEach([&stamps](KeyframeRecord keyframe) { stamps.push_back(keyframe.stamp_ns); });
    EXPECT_EQ(stamps.front(), exact);
  }
  // A map written before maps kept exact stamps: the table is absent; its keyframes' stamps are
  // their seconds, rounded, and opening it writes nothing (a damaged map is never written to).
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "DROP TABLE keyframe_stamps", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  const auto has_stamps_table = [this] {
    sqlite3* reader = nullptr;
    sqlite3_open_v2(path_.c_str(), &reader, SQLITE_OPEN_READONLY, nullptr);
    sqlite3_stmt* query = nullptr;
    sqlite3_prepare_v2(reader, "SELECT 1 FROM sqlite_schema WHERE name = 'keyframe_stamps'", -1,
                       &query, nullptr);
    const bool found = query != nullptr && sqlite3_step(query) == SQLITE_ROW;
    sqlite3_finalize(query);
    sqlite3_close(reader);
    return found;
  };
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    EXPECT_EQ(store->get(1)->stamp_ns, std::llround(exact * 1e-9 * 1e9));
  }
  EXPECT_FALSE(has_stamps_table()) << "opened and read: nothing written";
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    KeyframeRecord later = makeKeyframe(3, 1);
    later.stamp_ns = exact + 3000000000;
    store->add(later);
  }
  EXPECT_TRUE(has_stamps_table());
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->get(3)->stamp_ns, exact + 3000000000);
  EXPECT_EQ(store->size(), 3u);
}

TEST_F(KeyframeStoreTest, RefusesAnIdNotAfterTheLastAndKeepsWhatItHas) {
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  store->add(makeKeyframe(5, 0));
  EXPECT_THROW(store->add(makeKeyframe(5, 0)), std::runtime_error);
  EXPECT_THROW(store->add(makeKeyframe(3, 0)), std::runtime_error);
  EXPECT_EQ(store->size(), 1u);
  store->add(makeKeyframe(6, 0));
  EXPECT_EQ(store->size(), 2u);
}

TEST_F(KeyframeStoreTest, RefusesForeignNewerLockedAndNonRegularFiles) {
  { KeyframeStore::open(path_, kIdentity, kDimension)->add(makeKeyframe(1, 0)); }
  EXPECT_NE(openRefusal(path_, "type=other").find("other descriptors"), std::string::npos);
  EXPECT_NE(openRefusal(path_, kIdentity, 7).find("global descriptors of 6 values"),
            std::string::npos);

  {
    auto open_store = KeyframeStore::open(path_, kIdentity, kDimension);
    // A second node on the same map, as another process would be.
    const pid_t child = ::fork();
    if (child == 0) {
      const bool refused = openRefusal(path_).find("open in another process") != std::string::npos;
      ::_exit(refused ? 0 : 1);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the second open was not refused";
  }

  const std::string fifo = (folder_ / "fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NE(openRefusal(fifo).find("is not a regular file"), std::string::npos);
  EXPECT_NE(openRefusal(folder_.string()).find("is not a regular file"), std::string::npos);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5)) << "blocked";

  std::ofstream(folder_ / "text.db") << "not a map at all, just text that is long enough to be "
                                        "mistaken for nothing in particular\n";
  EXPECT_NE(openRefusal((folder_ / "text.db").string()).find("map "), std::string::npos);
  EXPECT_NE(openRefusal((folder_ / "missing" / "map.db").string()).find("cannot be written"),
            std::string::npos);
}

TEST_F(KeyframeStoreTest, RefusesAMapOfANewerFormat) {
  { KeyframeStore::open(path_, kIdentity, kDimension); }
  // Written as a newer version would: only its format number differs.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  EXPECT_EQ(sqlite3_exec(db, "UPDATE meta SET value = '99' WHERE key = 'format_version'", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_NE(openRefusal(path_).find("newer version (format 99"), std::string::npos);
}

TEST_F(KeyframeStoreTest, AFullDiskRefusesAKeyframeWithTheReasonAndLeavesTheMapWhole) {
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    for (uint64_t id = 1; id <= 3; ++id) store->add(makeKeyframe(id, 0));
  }
  // In a child, a file-size limit stands in for the full disk: writes past it fail as they do
  // when the disk has no room left.
  const std::string reason_file = (folder_ / "reason.txt").string();
  const pid_t child = ::fork();
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);  // Refused writes fail with EFBIG instead of killing.
    rlimit limit{};
    if (::getrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(4);
    const rlim_t unlimited = limit.rlim_cur;
    limit.rlim_cur = static_cast<rlim_t>(fs::file_size(path_) + (64 << 10));
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(4);
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    for (uint64_t id = 4; id < 10000; ++id) {
      try {
        store->add(makeKeyframe(id, 0));
      } catch (const std::runtime_error& error) {
        std::ofstream(reason_file) << id << "\n" << error.what();
        // Room again (the disk freed): the same store takes the keyframe.
        limit.rlim_cur = unlimited;
        if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(4);
        store->add(makeKeyframe(id, 0));
        ::_exit(0);
      }
    }
    ::_exit(3);  // Never refused.
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0) << "3: the limit never refused a keyframe; 4: no limit; "
                                       "else the store refused the keyframe once there was room";
  std::ifstream reason_in(reason_file);
  uint64_t refused = 0;
  reason_in >> refused;
  const std::string reason((std::istreambuf_iterator<char>(reason_in)),
                           std::istreambuf_iterator<char>());
  EXPECT_NE(reason.find(path_), std::string::npos) << reason;
  EXPECT_NE(reason.find("keyframe " + std::to_string(refused) + " not stored"), std::string::npos)
      << reason;

  // The map opens with every keyframe committed before the refused one and the one stored once
  // there was room.
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_EQ(store->size(), refused);
  for (uint64_t id = 1; id <= refused; ++id) {
    const std::optional<KeyframeRecord> keyframe = store->get(id);
    ASSERT_TRUE(keyframe) << id;
    expectSame(*keyframe, asStored(makeKeyframe(id, 0)));
  }
}

TEST_F(KeyframeStoreTest, AReadOnlyFolderIsRefusedWithTheReasonAndItsMapIsLeftAlone) {
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    store->add(makeKeyframe(1, 0));
  }
  const auto size_before = fs::file_size(path_);
  fs::permissions(folder_, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                               fs::perms::group_exec | fs::perms::others_read |
                               fs::perms::others_exec);
  fs::permissions(path_, fs::perms::all, fs::perm_options::add);  // The map itself stays writable.
  // In a child run as an ordinary user when the tests run as root (root writes anywhere).
  const std::string reasons_file =
      (fs::temp_directory_path() / "lcd_read_only_reasons.txt").string();
  const pid_t child = ::fork();
  if (child == 0) {
    if (::geteuid() == 0 && ::setuid(65534) != 0) ::_exit(4);
    std::ofstream reasons(reasons_file);
    for (const std::string& path : {(folder_ / "new.db").string(), path_}) {
      try {
        KeyframeStore::open(path, kIdentity, kDimension);
        reasons << path << ": opened\n";
      } catch (const std::runtime_error& error) {
        reasons << error.what() << "\n";
      }
    }
    reasons.close();  // _exit runs no destructor.
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  fs::permissions(folder_, fs::perms::owner_all, fs::perm_options::add);
  ASSERT_TRUE(WIFEXITED(status));
  if (WEXITSTATUS(status) == 4) GTEST_SKIP() << "root here cannot become an ordinary user";
  ASSERT_EQ(WEXITSTATUS(status), 0);
  std::ifstream reasons_in(reasons_file);
  std::string new_map, existing_map;
  std::getline(reasons_in, new_map);
  std::getline(reasons_in, existing_map);
  fs::remove(reasons_file);
  EXPECT_NE(new_map.find("new.db: its folder " + folder_.string() + " cannot be written"),
            std::string::npos)
      << new_map;
  EXPECT_EQ(existing_map.rfind("map " + path_ + ": ", 0), 0u) << existing_map;
  EXPECT_EQ(existing_map.find("opened"), std::string::npos) << existing_map;
  EXPECT_EQ(fs::file_size(path_), size_before);
  EXPECT_EQ(KeyframeStore::open(path_, kIdentity, kDimension)->size(), 1u);
}

TEST_F(KeyframeStoreTest, AWriterKilledMidRunLosesNoCommittedKeyframe) {
  int pipe_ends[2];
  ASSERT_EQ(::pipe(pipe_ends), 0);
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(pipe_ends[0]);
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    for (uint64_t id = 1;; ++id) {
      store->add(makeKeyframe(id, 0));
      // Reported only once add() returned: the parent counts on every reported id.
      if (::write(pipe_ends[1], &id, sizeof(id)) != sizeof(id)) ::_exit(1);
    }
  }
  ::close(pipe_ends[1]);
  uint64_t committed = 0;
  uint64_t id = 0;
  while (committed < 1000 && ::read(pipe_ends[0], &id, sizeof(id)) == sizeof(id)) committed = id;
  ::kill(child, SIGKILL);
  // Anything reported between the last read and the kill was committed too.
  while (::read(pipe_ends[0], &id, sizeof(id)) == sizeof(id)) committed = id;
  ::close(pipe_ends[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the writer was meant to be killed";
  ASSERT_GE(committed, 1000u);

  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  EXPECT_GE(store->size(), committed);
  EXPECT_LE(store->size(), committed + 1) << "at most the keyframe being written when killed";
  for (uint64_t check = 1; check <= committed; check += 37) {
    const std::optional<KeyframeRecord> keyframe = store->get(check);
    ASSERT_TRUE(keyframe) << "committed keyframe " << check << " lost";
    expectSame(*keyframe, asStored(makeKeyframe(check, 0)));
  }
  ASSERT_TRUE(store->get(committed));
  store->add(makeKeyframe(committed + 10, 1));  // And it goes on from there.
}

TEST_F(KeyframeStoreTest, CopiesAndBatchesAreWholeAndToolsOpenAnyMap) {
  KeyframeDatabase database(kDimension);
  for (uint64_t id = 1; id <= 20; ++id) database.add(makeKeyframe(id, id <= 10 ? 0 : 1));
  auto store = KeyframeStore::open(path_, kIdentity, kDimension);
  store->addAll(database);
  EXPECT_EQ(store->size(), 20u);
  EXPECT_THROW(store->addAll(database), std::runtime_error) << "ids not after the last";
  EXPECT_EQ(store->size(), 20u) << "a failed batch adds nothing";

  const std::string copy = (folder_ / "copy.db").string();
  std::ofstream(copy) << "an older copy";
  store->copyTo(copy);
  store.reset();

  auto opened = KeyframeStore::openExisting(copy);
  EXPECT_EQ(opened->descriptorIdentity(), kIdentity);
  EXPECT_EQ(opened->globalDimension(), kDimension);
  uint64_t next = 1;
  opened->forEach([&next](KeyframeRecord keyframe) {
    expectSame(keyframe, asStored(makeKeyframe(next, next <= 10 ? 0 : 1)));
    ++next;
  });
  EXPECT_EQ(next, 21u);
  EXPECT_THROW(KeyframeStore::openExisting((folder_ / "none.db").string()), std::runtime_error);
}

// A map's identity: kept across reopens, drawn anew by a copy; a map from before map ids draws
// one at open, writes it with its next commit only, and keeps it from then on.
TEST_F(KeyframeStoreTest, EveryMapHasItsOwnIdentityAndKeepsIt) {
  uint64_t original = 0;
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    original = store->mapId();
    EXPECT_NE(original, 0u);
    store->add(makeKeyframe(1, 0));
    const std::string copy = (folder_ / "copy.db").string();
    store->copyTo(copy);
    auto copied = KeyframeStore::openExisting(copy);
    EXPECT_NE(copied->mapId(), original) << "a copy grows apart from its original";
    EXPECT_EQ(copied->size(), 1u);
  }
  EXPECT_EQ(KeyframeStore::open(path_, kIdentity, kDimension)->mapId(), original);
  const std::string other = (folder_ / "other.db").string();
  EXPECT_NE(KeyframeStore::open(other, kIdentity, kDimension)->mapId(), original);

  // A map written before map ids.
  const auto storedId = [this]() -> std::string {
    sqlite3* db = nullptr;
    EXPECT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* select = nullptr;
    sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key = 'map_id'", -1, &select, nullptr);
    std::string value;
    if (sqlite3_step(select) == SQLITE_ROW) {
      value = reinterpret_cast<const char*>(sqlite3_column_text(select, 0));
    }
    sqlite3_finalize(select);
    sqlite3_close(db);
    return value;
  };
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "DELETE FROM meta WHERE key = 'map_id'", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  uint64_t drawn = 0;
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    drawn = store->mapId();
    EXPECT_NE(drawn, 0u);
  }
  EXPECT_EQ(storedId(), "") << "opened and closed without a commit: nothing written";
  {
    auto store = KeyframeStore::open(path_, kIdentity, kDimension);
    drawn = store->mapId();
    store->add(makeKeyframe(2, 1));
  }
  EXPECT_EQ(storedId(), std::to_string(drawn));
  EXPECT_EQ(KeyframeStore::open(path_, kIdentity, kDimension)->mapId(), drawn);
}

TEST(KeyframeRecordLayout, DepthsOnTheirRaysKeepOneValueOthersTheirCoordinates) {
  // A depth camera's keyframe: 400 keypoints, 300 with a depth, each point on its keypoint's
  // ray through a pinhole camera (fx 500, cx 320, fy 480, cy 240).
  KeyframeRecord camera = makeKeyframe(1, 0);
  LocalFeatures& local = camera.local_features;
  cv::RNG random(5);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  local.points.clear();
  local.points3d.clear();
  local.depth_sd.clear();
  for (int i = 0; i < 400; ++i) {
    const cv::Point2f pixel(static_cast<float>(random.uniform(0, 640 * 16)) / 16.0f,
                            static_cast<float>(random.uniform(0, 480 * 16)) / 16.0f);
    const float z = static_cast<float>(random.uniform(0.3, 12.0));
    local.points.push_back(pixel);
    local.points3d.push_back(i % 4 == 3 ? cv::Point3f(nan, nan, nan)
                                        : cv::Point3f(z * (pixel.x - 320.0f) / 500.0f,
                                                      z * (pixel.y - 240.0f) / 480.0f, z));
    local.depth_sd.push_back(i % 4 == 3 ? nan : 0.003f * z * z);
  }
  local.descriptors = cv::Mat(400, 32, CV_8U, cv::Scalar(7));
  // The same keypoints with points off their rays (a map edited by hand, another camera model).
  KeyframeRecord scattered = camera;
  for (cv::Point3f& point : scattered.local_features.points3d) point.x += 0.37f;

  for (const KeyframeRecord* keyframe : {&camera, &scattered}) {
    const std::vector<uint8_t> record = database_payload::encodeRecord(*keyframe);
    KeyframeRecord back;
    database_payload::decodeRecord(record.data(), record.size(), &back);
    back.id = keyframe->id;
    back.session = keyframe->session;
    back.stamp = keyframe->stamp;
    back.pose = keyframe->pose;
    back.path = keyframe->path;
    back.descriptor.global = in8Bits(keyframe->descriptor.global);
    expectSame(asStored(*keyframe), back);
  }
  const size_t on_rays = database_payload::encodeRecord(camera).size();
  const size_t off_rays = database_payload::encodeRecord(scattered).size();
  EXPECT_EQ(off_rays - on_rays, 300u * 2u * sizeof(uint16_t) - 4u * sizeof(float));
}
