// Saves never destroy: what a save may write to, how a map is kept aside, and the detector's
// save and reset on top of them. Never touches a real device node: a FIFO and a directory stand
// in for what is not a regular file.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <set>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "keyframe_fixtures.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/map_file_safety.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

class MapFileSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("lcd_map_safety_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
  }
  void TearDown() override { fs::remove_all(folder_); }

  std::string path(const std::string& name) const { return (folder_ / name).string(); }
  std::set<std::string> entries() const {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder_)) {
      names.insert(entry.path().filename().string());
    }
    return names;
  }
  static void write(const std::string& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
  }
  static std::string read(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  /// A detector holding 12 keyframes in memory.
  /// After the map's keyframes (stamps and places 0-11) when one is given.
  static std::unique_ptr<LoopDetector> detectorWithKeyframes(const std::string& map = "") {
    LoopDetectorOptions options = test_support::smallOptions();
    auto detector =
        std::make_unique<LoopDetector>(options, std::make_shared<test_support::PlaceExtractor>());
    const int first = map.empty() ? 0 : 1000;
    if (!map.empty()) {
      EXPECT_EQ(detector->map().load(map), "");
    }
    for (int i = first; i < first + 12; ++i) {
      EXPECT_TRUE(test_support::feed(detector.get(), i, i).keyframe);
    }
    return detector;
  }

  fs::path folder_;
};

TEST_F(MapFileSafety, ANewPathMayBeWritten) {
  EXPECT_EQ(saveTargetProblem(path("new.db"), "", false), "");
  EXPECT_EQ(saveTargetProblem(path("new.db"), "", true), "");
}

TEST_F(MapFileSafety, AnExistingFileNeedsOverwriteAndMustBeAMap) {
  write(path("notes.txt"), "my notes");
  const std::string refused = saveTargetProblem(path("notes.txt"), "", false);
  EXPECT_NE(refused.find("exists"), std::string::npos) << refused;
  const std::string not_a_map = saveTargetProblem(path("notes.txt"), "", true);
  EXPECT_NE(not_a_map.find("not a map"), std::string::npos) << not_a_map;
  EXPECT_EQ(read(path("notes.txt")), "my notes");
}

TEST_F(MapFileSafety, FifosDirectoriesAndBrokenCompanionsAreRefused) {
  ASSERT_EQ(::mkfifo(path("pipe").c_str(), 0600), 0);
  fs::create_directory(path("adir.db"));
  for (const bool overwrite : {false, true}) {
    const std::string fifo = saveTargetProblem(path("pipe"), "", overwrite);
    EXPECT_NE(fifo.find("FIFO"), std::string::npos) << fifo;
    const std::string folder = saveTargetProblem(path("adir.db"), "", overwrite);
    EXPECT_NE(folder.find("directory"), std::string::npos) << folder;
  }
  write(path("orphan.db-vectors"), "rows of a map moved away");
  const std::string orphan = saveTargetProblem(path("orphan.db"), "", true);
  EXPECT_NE(orphan.find("without its map"), std::string::npos) << orphan;
  const std::string missing = saveTargetProblem(path("no/such/folder/map.db"), "", false);
  EXPECT_NE(missing.find("does not exist"), std::string::npos) << missing;
}

TEST_F(MapFileSafety, TheLiveMapIsRecognisedUnderAnyName) {
  write(path("live.db"), "SQLite format 3");
  fs::create_symlink(path("live.db"), path("alias.db"));
  const std::string link = saveTargetProblem(path("alias.db"), path("live.db"), true);
  EXPECT_NE(link.find("open map itself"), std::string::npos) << link;
  const std::string spelled =
      saveTargetProblem(folder_.string() + "/./live.db", path("live.db"), true);
  EXPECT_NE(spelled.find("open map itself"), std::string::npos) << spelled;
}

TEST_F(MapFileSafety, KeepingAsideNeverReusesAName) {
  std::set<std::string> kept;
  for (int round = 0; round < 3; ++round) {  // Within one second: the names still differ.
    write(path("map.db"), "map " + std::to_string(round));
    write(path("map.db-vectors"), "rows " + std::to_string(round));
    const std::string name = moveMapAside(path("map.db"), "reset");
    EXPECT_TRUE(kept.insert(name).second) << name;
    EXPECT_FALSE(fs::exists(path("map.db")));
    EXPECT_EQ(read(name), "map " + std::to_string(round));
    EXPECT_EQ(read(name + "-vectors"), "rows " + std::to_string(round));
  }
  EXPECT_EQ(entries().size(), 6u);
}

TEST_F(MapFileSafety, DetectorSaveRefusesAndLeavesNothing) {
  auto detector = detectorWithKeyframes();
  ASSERT_EQ(::mkfifo(path("pipe").c_str(), 0600), 0);
  fs::create_directory(path("adir.db"));
  write(path("notes.txt"), "my notes");
  const std::set<std::string> before = entries();
  EXPECT_NE(detector->map().save(path("pipe")), "");
  EXPECT_NE(detector->map().save(path("pipe"), true), "");
  EXPECT_NE(detector->map().save(path("adir.db")), "");
  EXPECT_NE(detector->map().save(path("notes.txt")), "");
  EXPECT_NE(detector->map().save(path("notes.txt"), true), "");
  EXPECT_EQ(entries(), before);  // No stray -vectors, no partial file.
  EXPECT_TRUE(fs::is_fifo(path("pipe")));
  EXPECT_EQ(read(path("notes.txt")), "my notes");
}

TEST_F(MapFileSafety, DetectorOverwriteKeepsTheEarlierMap) {
  auto first = detectorWithKeyframes();
  ASSERT_EQ(first->map().save(path("map.db")), "");
  const std::string refused = first->map().save(path("map.db"));
  EXPECT_NE(refused.find("exists"), std::string::npos) << refused;
  std::string kept;
  ASSERT_EQ(first->map().save(path("map.db"), true, &kept), "");
  ASSERT_FALSE(kept.empty());
  EXPECT_TRUE(fs::exists(kept));
  EXPECT_TRUE(fs::exists(path("map.db")));
  // Both are maps with the 12 keyframes.
  for (const std::string& map : {path("map.db"), kept}) {
    LoopDetector reader(test_support::smallOptions(),
                        std::make_shared<test_support::PlaceExtractor>());
    EXPECT_EQ(reader.map().load(map), "") << map;
    EXPECT_EQ(reader.database().size(), 12u) << map;
  }
}

TEST_F(MapFileSafety, DetectorRefusesItsOwnMapUnderAnotherName) {
  {
    auto writer = detectorWithKeyframes();
    ASSERT_EQ(writer->map().save(path("map.db")), "");
  }
  auto live = detectorWithKeyframes(path("map.db"));
  EXPECT_EQ(live->map().save(path("map.db")), "");  // Its own path: a commit.
  fs::create_symlink(path("map.db"), path("alias.db"));
  const std::string alias = live->map().save(path("alias.db"), true);
  EXPECT_NE(alias.find("open map itself"), std::string::npos) << alias;
}

TEST_F(MapFileSafety, TwoResetsKeepBothEarlierMaps) {
  {
    auto writer = detectorWithKeyframes();
    ASSERT_EQ(writer->map().save(path("map.db")), "");
  }
  auto live = detectorWithKeyframes(path("map.db"));  // 12 loaded + 12 new.
  const MapSession::ResetOutcome first = live->map().reset();
  ASSERT_EQ(first.problem, "");
  ASSERT_NE(first.kept_as, "");
  for (int i = 1012; i < 1017; ++i) {
    const FrameResult result = test_support::feed(live.get(), i, i);
    ASSERT_TRUE(result.keyframe);
    EXPECT_FALSE(result.keyframe->error) << result.keyframe->error->message;
  }
  const MapSession::ResetOutcome second = live->map().reset();
  ASSERT_EQ(second.problem, "") << live->database().size();
  ASSERT_NE(second.kept_as, "");
  const std::string& first_name = first.kept_as;
  const std::string& second_name = second.kept_as;
  EXPECT_NE(first_name, second_name);
  live.reset();
  for (const auto& [map, keyframes] :
       std::vector<std::pair<std::string, size_t>>{{first_name, 24u}, {second_name, 5u}}) {
    LoopDetector reader(test_support::smallOptions(),
                        std::make_shared<test_support::PlaceExtractor>());
    EXPECT_EQ(reader.map().load(map), "") << map;
    EXPECT_EQ(reader.database().size(), keyframes) << map;
  }
}

// What is not a map - an empty file, another program's database, a text file - is refused by
// open (at start) and by load, and left exactly as it was: nothing is created in it or beside it.
TEST_F(MapFileSafety, AnEmptyForeignOrTextFileIsNoMapAndIsLeftAlone) {
  write(path("empty.db"), "");
  write(path("notes.db"), "not a map\n");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path("other.db").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE contacts (name TEXT); INSERT INTO contacts VALUES ('a')",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  const std::set<std::string> before = entries();
  for (const auto& [name, reason] : std::vector<std::pair<std::string, std::string>>{
           {"empty.db", "is an empty file, not a map"},
           {"notes.db", "is not a map (not an SQLite database)"},
           {"other.db", "is an SQLite database but not a keyframe map"}}) {
    const std::string bytes = read(path(name));
    std::string refused;
    try {
      KeyframeStore::open(path(name), "test", 8);
    } catch (const std::exception& error) {
      refused = error.what();
    }
    EXPECT_NE(refused.find("map " + path(name) + ": " + reason), std::string::npos) << refused;
    auto detector = detectorWithKeyframes();
    const std::string load = detector->map().load(path(name));
    EXPECT_NE(load.find(reason), std::string::npos) << load;
    EXPECT_EQ(detector->database().size(), 12u) << "the map in use is kept";
    EXPECT_TRUE(read(path(name)) == bytes) << name << " was changed";
    EXPECT_EQ(entries(), before) << name;
  }
}

}  // namespace

TEST_F(MapFileSafety, AMapWhoseWriterWasKilledIsKeptAsideWhole) {
  // A writer that stores 300 keyframes and is killed: its last commits are only in A.db-wal.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    try {
      auto store = KeyframeStore::open(path("A.db"), kIdentity, kDimension);
      for (uint64_t id = 0; id < 300; ++id) store->add(makeKeyframe(id, 0));
      ::_exit(0);  // Killed: nothing closes the map, its log is not folded in.
    } catch (...) {
      ::_exit(1);
    }
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  ASSERT_TRUE(fs::exists(path("A.db-wal")));
  ASSERT_GT(fs::file_size(path("A.db-wal")), 0u);
  // Another map is saved over it: the one that was there is kept with every commit.
  auto detector = detectorWithKeyframes();
  std::string kept;
  ASSERT_EQ(detector->map().save(path("A.db"), true, &kept), "");
  EXPECT_TRUE(fs::exists(kept + "-wal") || !fs::exists(path("A.db-wal")));
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 300u);
  LoopDetector reader(test_support::smallOptions(),
                      std::make_shared<test_support::PlaceExtractor>());
  EXPECT_EQ(reader.map().load(path("A.db")), "");
  EXPECT_EQ(reader.database().size(), 12u);
}

TEST_F(MapFileSafety, AJournalWithoutItsMapIsNeverDeleted) {
  write(path("stray.db-wal"), "another map's last commits");
  auto detector = detectorWithKeyframes();
  const std::string refused = detector->map().save(path("stray.db"));
  EXPECT_NE(refused.find("stray.db-wal"), std::string::npos) << refused;
  EXPECT_THROW(KeyframeStore::open(path("stray.db"), kIdentity, kDimension), std::runtime_error);
  EXPECT_EQ(read(path("stray.db-wal")), "another map's last commits");
  EXPECT_FALSE(fs::exists(path("stray.db")));
}

TEST_F(MapFileSafety, AMapAnotherProcessStillWritesIsNotReplaced) {
  // A node still mapping to A.db in another process: a save with overwrite must not move its
  // map from under it.
  int ready[2];
  int finish[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(finish), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(ready[0]);
    ::close(finish[1]);
    try {
      auto store = KeyframeStore::open(path("A.db"), kIdentity, kDimension);
      for (uint64_t id = 0; id < 20; ++id) store->add(makeKeyframe(id, 0));
      const char byte = 1;
      if (::write(ready[1], &byte, 1) != 1) ::_exit(1);
      char done;
      while (::read(finish[0], &done, 1) > 0) {
      }
      ::_exit(0);
    } catch (...) {
      ::_exit(1);
    }
  }
  ::close(ready[1]);
  ::close(finish[0]);
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1);
  auto detector = detectorWithKeyframes();
  const std::set<std::string> before = entries();
  std::string kept;
  const std::string refused = detector->map().save(path("A.db"), true, &kept);
  EXPECT_NE(refused.find("is open in another process (pid " + std::to_string(child) + ")"),
            std::string::npos)
      << refused;
  EXPECT_TRUE(kept.empty());
  EXPECT_EQ(entries(), before);
  // Once it has stopped, the map it left is kept aside whole and the save goes ahead.
  ::close(finish[1]);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  ASSERT_EQ(detector->map().save(path("A.db"), true, &kept), "");
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 20u);
  ::close(ready[0]);
}
