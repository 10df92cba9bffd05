// The map's life without a detector: MapSession opens a map, stores keyframes in it, saves a copy,
// adopts a map read elsewhere and resets, telling its user before it saves or replaces the map and
// after another map is searched. test_loop_detector_map covers the same through the detector.
#include <filesystem>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "keyframe_fixtures.h"
#include "landmark_loop_closure/core/map_session.h"

namespace landmark_loop_closure {
namespace {

// Records what the map told it.
struct RecordingUser : MapUser {
  int held_stored = 0;
  struct Replaced {
    uint32_t first_session;
    std::optional<uint64_t> next_id;
  };
  std::vector<Replaced> replaced;

  void storeHeldKeyframes() override { ++held_stored; }
  void mapReplaced(uint32_t first_session, std::optional<uint64_t> next_id) override {
    replaced.push_back({first_session, next_id});
  }
};

MapSession::Settings testSettings(const std::string& identity = kIdentity) {
  MapSession::Settings settings;
  settings.global_dimension = kDimension;
  settings.descriptor_identity = identity;
  return settings;
}

using MapSessionTest = MapFolderTest;

TEST_F(MapSessionTest, StoresSavesAdoptsAndResetsOnItsOwn) {
  RecordingUser user;
  MapSession map(testSettings(), &user);
  EXPECT_EQ(map.path(), "");
  const uint64_t memory_map = map.mapId();
  ASSERT_EQ(map.open(path_), "");
  EXPECT_EQ(user.held_stored, 1);  // What it held belongs to the map open until then.
  ASSERT_EQ(user.replaced.size(), 1u);
  EXPECT_EQ(user.replaced[0].first_session, 0u);  // An empty map: the first session.
  EXPECT_FALSE(user.replaced[0].next_id.has_value());
  EXPECT_NE(map.mapId(), memory_map);
  for (uint64_t id = 0; id < 5; ++id) {
    const StoredKeyframe stored = map.store(makeKeyframe(id, 0));
    EXPECT_TRUE(stored.stored);
    EXPECT_EQ(stored.store_error, "");
    EXPECT_FALSE(stored.written_not_searched);
  }
  EXPECT_EQ(map.database().size(), 5u);
  EXPECT_EQ(map.keyframesInFile(), 5u);
  EXPECT_EQ(map.keyframesNotWritten(), 0u);

  // A copy: the user stores what it holds back first.
  const std::string copy = (folder_ / "copy.db").string();
  EXPECT_EQ(map.save(copy), "");
  EXPECT_EQ(user.held_stored, 2);
  EXPECT_NE(map.save(copy).find("exists"), std::string::npos) << "never over a file unasked";

  // Another session adopts the copy read beside it: new keyframes after its ids, next session.
  RecordingUser other_user;
  MapSession other(testSettings(), &other_user);
  ASSERT_EQ(other.adopt(readMap(copy, other.readSettings())), "");
  ASSERT_EQ(other_user.replaced.size(), 1u);
  EXPECT_EQ(other_user.replaced[0].first_session, 1u);
  EXPECT_EQ(other_user.replaced[0].next_id, std::optional<uint64_t>(5));
  EXPECT_EQ(other.database().size(), 5u);
  EXPECT_EQ(other.path(), copy);

  // A map read for another descriptor is refused, and nothing changes.
  MapSession::Settings foreign = testSettings("type=other dimension=6");
  ReadMap read_for_other = readMap((folder_ / "other.db").string(), [&] {
    MapSession reader(foreign, nullptr);
    return reader.readSettings();
  }());
  EXPECT_NE(other.adopt(std::move(read_for_other)).find("another descriptor"), std::string::npos);
  EXPECT_EQ(other.path(), copy);
  EXPECT_EQ(other_user.replaced.size(), 1u);

  // A reset keeps the map under a new name and starts a fresh one at its path.
  const uint64_t before_reset = map.mapId();
  const MapSession::ResetOutcome outcome = map.reset();
  EXPECT_EQ(outcome.problem, "");
  ASSERT_FALSE(outcome.kept_as.empty());
  EXPECT_TRUE(std::filesystem::exists(outcome.kept_as));
  EXPECT_EQ(user.held_stored, 4);  // The open, the two saves and the reset.
  ASSERT_EQ(user.replaced.size(), 2u);
  EXPECT_EQ(user.replaced[1].first_session, 0u);
  EXPECT_TRUE(map.database().empty());
  EXPECT_EQ(map.path(), path_);
  EXPECT_NE(map.mapId(), before_reset);
  MapSession kept(testSettings(), nullptr);
  ASSERT_EQ(kept.load(outcome.kept_as), "");
  EXPECT_EQ(kept.database().size(), 5u) << "a reset never shortens a saved map";
}

TEST_F(MapSessionTest, LoadRefusesAMissingFileAndOpenCreatesIt) {
  MapSession map(testSettings(), nullptr);
  EXPECT_NE(map.load(path_).find("does not exist"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path_));
  EXPECT_EQ(map.open(path_), "");
  EXPECT_TRUE(std::filesystem::exists(path_));
  EXPECT_EQ(map.check() == "checked" || map.check() == "being checked", true) << map.check();
}

}  // namespace
}  // namespace landmark_loop_closure
