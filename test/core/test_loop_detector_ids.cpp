// The ids and stamps a map gives its keyframes: never published twice for two frames (a crash
// in the warm-up, a localisation run, a map loaded mid-run), published only once the file holds
// them, and stamps kept to the nanosecond. Split from test_loop_detector_map.cpp.
#include <chrono>
#include <csignal>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "landmark_loop_closure/core/loop_detector.h"
#include "map_files.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::place;
using test_support::PlaceExtractor;

using test_support::feed;
using test_support::removeMap;
using test_support::smallOptions;
using test_support::temporaryPath;

// Keyframes published while the standardisation warms up are stored only once its window fills:
// killed before that, the map must still keep their ids from the next run (issue 67 point 3).
TEST(LoopDetector, IdsPublishedDuringTheWarmUpAreNotGivenAgainAfterACrash) {
  const std::string path = temporaryPath("warm_up_ids.lcdb");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.descriptor.condition_window = 6;
  uint64_t map_id = 0;
  {
    LoopDetector mapped(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(mapped.map().open(path), "");
    for (int i = 0; i < 8; ++i) feed(&mapped, i, 100 + i);  // Ids 0-4 held, stored at id 5.
    map_id = mapped.map().mapId();
  }
  auto store = KeyframeStore::openExisting(path);
  ASSERT_TRUE(store->idsReservedThrough());
  EXPECT_EQ(*store->idsReservedThrough(), 4u);
  store.reset();
  {
    // A crash in the warm-up of a run on that map: ids 8-10 published, none stored. Simulated by
    // marking them as the warm-up does, without the detector's clean stop.
    auto crashed = KeyframeStore::openExisting(path);
    crashed->reserveIdsThrough(10);
  }
  LoopDetector next_run(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next_run.map().open(path), "");
  EXPECT_EQ(next_run.map().mapId(), map_id);
  const FrameResult first = feed(&next_run, 20, 200);
  ASSERT_TRUE(first.keyframe);
  EXPECT_EQ(first.keyframe->keyframe_id, 11u) << "not 8: ids 8-10 went out before the crash";
  removeMap(path);
}

// Issue 67 point 3: a localisation run publishes keyframes under the map's id without storing
// them; a mapping run on that map later must not publish those ids again for other frames.
TEST(LoopDetector, IdsALocalisationRunPublishedAreNeverGivenAgainByMapping) {
  const std::string path = temporaryPath("localisation_ids.lcdb");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  {
    LoopDetector mapped(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(mapped.map().open(path), "");
    for (int i = 0; i < 12; ++i) feed(&mapped, i, 100 + i);  // Ids 0-11 stored.
  }
  std::set<uint64_t> published;
  uint64_t map_id = 0;
  {
    LoopDetector localising(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(localising.map().open(path), "");
    localising.setMode(DetectorMode::kLocalization);
    map_id = localising.map().mapId();
    for (int i = 0; i < 8; ++i) {
      const FrameResult result = feed(&localising, 20 + i, 300 + i);
      ASSERT_TRUE(result.keyframe);
      EXPECT_TRUE(result.keyframe->store_error.empty()) << result.keyframe->store_error;
      published.insert(result.keyframe->keyframe_id);
    }
    EXPECT_EQ(localising.database().size(), 12u) << "localisation stores nothing";
  }  // Stopped without a save, as a kill would.
  ASSERT_EQ(published.size(), 8u);
  LoopDetector mapping(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(mapping.map().open(path), "");
  EXPECT_EQ(mapping.map().mapId(), map_id);
  for (int i = 0; i < 8; ++i) {
    const FrameResult result = feed(&mapping, 40 + i, 400 + i);
    ASSERT_TRUE(result.keyframe);
    EXPECT_EQ(published.count(result.keyframe->keyframe_id), 0u)
        << "keyframe id " << result.keyframe->keyframe_id << " went out in localisation";
  }
  removeMap(path);
}

// A backend keys its graph on (map id, keyframe id): a map loaded mid-run keeps ids that were
// published before (it was stored with them), so the map id must change with the map.
TEST(LoopDetector, AMapLoadedMidRunKeepsItsIdsUnderItsOwnMapId) {
  const std::string path = temporaryPath("mid_run_map.lcdb");
  removeMap(path);
  uint64_t saved_map = 0;
  {
    LoopDetector earlier(smallOptions(), std::make_shared<PlaceExtractor>());
    ASSERT_EQ(earlier.map().open(path), "");
    for (int i = 0; i < 10; ++i) feed(&earlier, i, 100 + i);  // Ids 0-9, places 100-109.
    saved_map = earlier.map().mapId();
  }
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  const uint64_t first_map = detector.map().mapId();
  for (int i = 0; i < 20; ++i) feed(&detector, i, i);  // Ids 0-19 published in memory.
  EXPECT_EQ(detector.map().mapId(), first_map);
  ASSERT_EQ(detector.map().load(path), "");
  EXPECT_EQ(detector.map().mapId(), saved_map);
  EXPECT_NE(detector.map().mapId(), first_map);
  EXPECT_EQ(detector.database().summary(0).id, 0u) << "the loaded map keeps its own ids";

  // A revisit of the loaded map: its loop names the loaded map, new ids go on after 19.
  std::optional<AcceptedLoop> loop;
  for (int i = 0; i < 4 && !loop; ++i) {
    const FrameResult result = feed(&detector, 20 + i, 103 + i);
    ASSERT_TRUE(result.keyframe);
    EXPECT_GE(result.keyframe->keyframe_id, 20u);
    loop = result.keyframe->loop;
  }
  ASSERT_TRUE(loop);
  EXPECT_EQ(loop->map_id, saved_map);
  EXPECT_LT(loop->match_id, 10u);

  detector.map().reset();
  EXPECT_NE(detector.map().mapId(), saved_map) << "a reset starts a new map";
  EXPECT_NE(detector.map().mapId(), 0u);
  removeMap(path);
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::temp_directory_path())) {
    if (entry.path().string().rfind(path + ".reset-", 0) == 0) removeMap(entry.path().string());
  }
}

// Issue 67 point 3: a keyframe published and lost to a crash leaves a (map_id, id) a backend holds
// and no map has. The node publishes what takeAnnounced() gives: only keyframes the file holds,
// so the warm-up's are announced when the window fills and the check's once it passes. A child
// process maps and dies as a kill would (no destructor, nothing flushed); every keyframe it
// announced must be in the file it left.
TEST(LoopDetector, AKeyframeIsAnnouncedOnlyOnceTheMapFileHoldsIt) {
  const std::string path = temporaryPath("announced.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.descriptor.condition_window = 4;
  {
    LoopDetector earlier(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(earlier.map().open(path), "");
    for (int i = 0; i < 20; ++i) feed(&earlier, i, 100 + i);
  }
  for (const int killed_after : {21, 26}) {
    int pipe_ends[2];
    ASSERT_EQ(pipe(pipe_ends), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      close(pipe_ends[0]);
      LoopDetector detector(options, std::make_shared<PlaceExtractor>());
      detector.map().announceKeyframes(true);
      if (!detector.map().open(path).empty()) _exit(2);
      // The map's check runs beside the first keyframes and holds them until it passes: waited
      // for here, so that on a busy machine the kill still comes after keyframes were announced.
      for (int wait = 0; wait < 1000 && detector.map().check() != "checked"; ++wait) usleep(10000);
      const int first =
          static_cast<int>(detector.database().summary(detector.database().size() - 1).id) + 1;
      for (int i = first; i <= killed_after + first - 20; ++i) {
        feed(&detector, i, i - 15);
        for (const AnnouncedKeyframe& keyframe : detector.map().takeAnnounced()) {
          const uint64_t id = keyframe.summary.id;
          if (write(pipe_ends[1], &id, sizeof(id)) != sizeof(id)) _exit(3);
        }
      }
      raise(SIGKILL);  // Killed: no destructor stores or flushes anything, no thread joined.
    }
    close(pipe_ends[1]);
    std::vector<uint64_t> announced;
    uint64_t id = 0;
    while (read(pipe_ends[0], &id, sizeof(id)) == sizeof(id)) announced.push_back(id);
    close(pipe_ends[0]);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "the child failed first: " << status;
    const std::unique_ptr<KeyframeStore> left = KeyframeStore::openExisting(path);
    for (const uint64_t published : announced) {
      EXPECT_TRUE(left->get(published).has_value())
          << "keyframe " << published << " was announced and is not in the map a kill left";
    }
    if (killed_after == 21) {
      EXPECT_TRUE(announced.empty()) << "the first keyframes wait for the condition window";
    } else {
      EXPECT_GE(announced.size(), 1u);
    }
  }

  // Localising stores nothing: announced once the map holds its id's reservation, which is
  // written once the map's check has passed (milliseconds here).
  LoopDetector localising(options, std::make_shared<PlaceExtractor>());
  localising.map().announceKeyframes(true);
  ASSERT_EQ(localising.map().open(path), "");
  localising.setMode(DetectorMode::kLocalization);
  const FrameResult result = feed(&localising, 100, 3);
  ASSERT_TRUE(result.keyframe);
  std::vector<AnnouncedKeyframe> localised;
  for (int wait = 0; wait < 500 && localised.empty(); ++wait) {
    localised = localising.map().takeAnnounced();
    if (localised.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(localised.size(), 1u);
  EXPECT_EQ(localised[0].summary.id, result.keyframe->keyframe_id);
  EXPECT_EQ(localised[0].map_id, localising.map().mapId());
  removeMap(path);
}

// The node publishes a loaded keyframe's stamp from its map: the camera's to the nanosecond.
TEST(LoopDetector, ALoadedKeyframeKeepsItsStampToTheNanosecond) {
  const std::string path = temporaryPath("exact_stamps.db");
  removeMap(path);
  const int64_t first_ns = 1700000000123456789;
  {
    LoopDetector mapped(smallOptions(), std::make_shared<PlaceExtractor>());
    ASSERT_EQ(mapped.map().open(path), "");
    for (int i = 0; i < 3; ++i) {
      const int64_t stamp_ns = first_ns + i * 1000000001LL;
      const double stamp = static_cast<double>(stamp_ns) * 1e-9;
      const FrameAdmission admission =
          mapped.admit(stamp, planarPose(i, 0, 0), place(i).cols, place(i).rows, place(i).type());
      ASSERT_TRUE(admission.isKeyframe());
      mapped.addKeyframe(admission.keyframe_id, stamp, planarPose(i, 0, 0), place(i), {}, {},
                         stamp_ns);
    }
    EXPECT_EQ(mapped.map().keyframeStampNs(2), first_ns + 2000000002LL)
        << "this run's, from memory";
  }
  LoopDetector loaded(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(loaded.map().open(path), "");
  for (uint64_t id = 0; id < 3; ++id) {
    ASSERT_TRUE(loaded.map().keyframeStampNs(id)) << id;
    EXPECT_EQ(*loaded.map().keyframeStampNs(id),
              first_ns + static_cast<int64_t>(id) * 1000000001LL);
  }
  EXPECT_FALSE(loaded.map().keyframeStampNs(7));
  removeMap(path);
}
