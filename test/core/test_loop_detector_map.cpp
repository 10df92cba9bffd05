// The detector with a map file: sessions, the map kept on disk as keyframes come, its search
// graph, the memory budget at open and a damaged rows file found while search runs.
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "landmark_loop_closure/core/loop_detector.h"
#include "map_damage.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::place;
using test_support::PlaceExtractor;

using test_support::feed;
using test_support::smallOptions;

namespace {

std::string temporaryPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("lcd_detector_" + name)).string();
}

/// A map file and what SQLite and the map leave beside it.
void removeMap(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm", "-vectors", "-graph", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
}

}  // namespace

TEST(LoopDetector, ASavedMapIsRecognisedInTheNextSession) {
  const std::string path = temporaryPath("saved_map.lcdb");
  removeMap(path);  // A save never replaces a file: start from none.
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  {
    LoopDetector first_run(options, std::make_shared<PlaceExtractor>());
    for (int i = 0; i < 40; ++i) feed(&first_run, i, i);
    ASSERT_EQ(first_run.saveDatabase(path), "");
  }
  // The next day: the odometry starts again at another origin, stamps go on.
  LoopDetector next_run(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next_run.loadDatabase(path), "");
  EXPECT_EQ(next_run.database().size(), 40u);
  EXPECT_EQ(next_run.session(), 1u);
  std::optional<AcceptedLoop> loop;
  bool found_the_maps_last_keyframe = false;
  for (int i = 0; i < 3; ++i) {
    const FrameResult result =
        next_run.process(100000.0 + i, planarPose(500.0 + i, 0, 0), place(37 + i));
    ASSERT_TRUE(result.keyframe);
    EXPECT_GE(result.keyframe->keyframe_id, 40u);  // Never an id of the loaded map.
    for (const CandidateReport& report : result.keyframe->candidates) {
      // 500 m from the map's poses, but the map's odometry frame is another run's: no gate.
      EXPECT_NE(report.verdict, CandidateVerdict::kOdometryRejected) << report.detail;
      found_the_maps_last_keyframe |= report.match_id == 39u;
    }
    if (result.keyframe->loop) loop = result.keyframe->loop;
  }
  EXPECT_TRUE(found_the_maps_last_keyframe);  // Not excluded as "recent".
  ASSERT_TRUE(loop);
  EXPECT_EQ(loop->match_id, 39u);
  EXPECT_EQ(loop->match_session, 0u);
  ASSERT_EQ(next_run.database().size(), 43u);
  EXPECT_EQ(next_run.database().record(42)->session, 1u);
  EXPECT_EQ(next_run.database().record(42)->id, 42u);
  removeMap(path);
}

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
    ASSERT_EQ(mapped.openMap(path), "");
    for (int i = 0; i < 8; ++i) feed(&mapped, i, 100 + i);  // Ids 0-4 held, stored at id 5.
    map_id = mapped.mapId();
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
  ASSERT_EQ(next_run.openMap(path), "");
  EXPECT_EQ(next_run.mapId(), map_id);
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
    ASSERT_EQ(mapped.openMap(path), "");
    for (int i = 0; i < 12; ++i) feed(&mapped, i, 100 + i);  // Ids 0-11 stored.
  }
  std::set<uint64_t> published;
  uint64_t map_id = 0;
  {
    LoopDetector localising(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(localising.openMap(path), "");
    localising.setMode(DetectorMode::kLocalization);
    map_id = localising.mapId();
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
  ASSERT_EQ(mapping.openMap(path), "");
  EXPECT_EQ(mapping.mapId(), map_id);
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
    ASSERT_EQ(earlier.openMap(path), "");
    for (int i = 0; i < 10; ++i) feed(&earlier, i, 100 + i);  // Ids 0-9, places 100-109.
    saved_map = earlier.mapId();
  }
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  const uint64_t first_map = detector.mapId();
  for (int i = 0; i < 20; ++i) feed(&detector, i, i);  // Ids 0-19 published in memory.
  EXPECT_EQ(detector.mapId(), first_map);
  ASSERT_EQ(detector.loadDatabase(path), "");
  EXPECT_EQ(detector.mapId(), saved_map);
  EXPECT_NE(detector.mapId(), first_map);
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

  detector.reset();
  EXPECT_NE(detector.mapId(), saved_map) << "a reset starts a new map";
  EXPECT_NE(detector.mapId(), 0u);
  removeMap(path);
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::temp_directory_path())) {
    if (entry.path().string().rfind(path + ".reset-", 0) == 0) removeMap(entry.path().string());
  }
}

TEST(LoopDetector, ARefusedLoadChangesNothingAndResetForgetsAll) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  const std::string error = detector.loadDatabase(temporaryPath("missing.lcdb"));
  EXPECT_NE(error.find("missing.lcdb"), std::string::npos) << error;
  EXPECT_EQ(detector.database().size(), 12u);
  EXPECT_EQ(detector.session(), 0u);

  // A map made with other descriptors is refused the same way.
  const std::string path = temporaryPath("other_descriptors.lcdb");
  removeMap(path);
  LoopDetectorOptions hog = smallOptions();
  hog.descriptor.type = "hog";
  {
    LoopDetector other(hog, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(other.saveDatabase(path), "");
  }
  const std::string refused = detector.loadDatabase(path);
  EXPECT_NE(refused.find("other descriptors"), std::string::npos) << refused;
  EXPECT_NE(refused.find("type is hog in the map"), std::string::npos) << "names what differs";
  EXPECT_EQ(detector.database().size(), 12u);
  removeMap(path);

  detector.reset();
  EXPECT_TRUE(detector.database().empty());
  EXPECT_FALSE(feed(&detector, 12, 12).keyframe->error);
  EXPECT_EQ(detector.database().size(), 1u);
}

TEST(LoopDetector, AnOpenMapHasEveryStoredKeyframeAndAResetKeepsItAside) {
  const std::string path = temporaryPath("open_map.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    EXPECT_EQ(detector.mapPath(), path);
    for (int i = 0; i < 15; ++i) feed(&detector, i, i);
  }  // No save: every keyframe was committed when it was stored.
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  EXPECT_EQ(detector.database().size(), 15u);
  EXPECT_EQ(detector.session(), 1u);

  const LoopDetector::ResetOutcome outcome = detector.reset();
  EXPECT_EQ(outcome.problem, "");
  EXPECT_EQ(outcome.kept_as.rfind(path + ".reset-", 0), 0u) << outcome.kept_as;
  EXPECT_TRUE(detector.database().empty());
  feed(&detector, 20, 20);
  const std::string kept = outcome.kept_as;
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 15u) << "the reset map is whole";
  removeMap(path);
  removeMap(kept);
}

TEST(LoopDetector, TheFirstKeyframesWaitForAFullConditionWindowAndAreDescribedByIt) {
  LoopDetectorOptions options = smallOptions();
  options.descriptor.condition_window = 4;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 3; ++i) {
    const FrameResult result = feed(&detector, i, 10 + i);
    ASSERT_TRUE(result.keyframe);
    EXPECT_TRUE(result.keyframe->stored);
  }
  EXPECT_EQ(detector.database().size(), 0u) << "kept back while the window warms up";
  feed(&detector, 3, 13);
  ASSERT_EQ(detector.database().size(), 4u);
  // Each is its one-hot place less the first full window's mean (a quarter on places 10-13).
  for (size_t k = 0; k < 4; ++k) {
    std::vector<float> expected(256, 0.0f);
    for (int other = 10; other < 14; ++other) expected[other] = -0.25f;
    expected[10 + k] += 1.0f;
    double norm = 0.0;
    for (float value : expected) norm += value * value;
    for (float& value : expected) value /= static_cast<float>(std::sqrt(norm));
    EXPECT_GT(detector.database().similarity(expected, k), 0.99) << "keyframe " << k;
  }
  feed(&detector, 4, 14);
  EXPECT_EQ(detector.database().size(), 5u) << "stored at once from then on";
}

TEST(LoopDetector, KeyframesWaitingForTheConditionWindowAreKeptBySaveAndByTheEnd) {
  const std::string saved = temporaryPath("warming_saved.lcdb");
  const std::string open = temporaryPath("warming_open.lcdb");
  removeMap(saved);
  removeMap(open);
  LoopDetectorOptions options = smallOptions();
  options.descriptor.condition_window = 10;
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    for (int i = 0; i < 3; ++i) feed(&detector, i, 10 + i);
    ASSERT_EQ(detector.saveDatabase(saved), "");
    EXPECT_EQ(detector.database().size(), 3u);
  }
  EXPECT_EQ(KeyframeStore::openExisting(saved)->size(), 3u);
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(open), "");
    for (int i = 0; i < 5; ++i) feed(&detector, i, 10 + i);
  }  // Shut down before the window filled.
  EXPECT_EQ(KeyframeStore::openExisting(open)->size(), 5u);
  removeMap(saved);
  removeMap(open);
}

TEST(LoopDetector, AResetSaysSoWhenTheMapCouldNotBeKeptAside) {
  const std::filesystem::path folder = temporaryPath("reset_gone");
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  const std::string path = (folder / "map.db").string();
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  // The map's folder is deleted under the running detector (a cleanup script, a full disk).
  std::filesystem::remove_all(folder);
  const LoopDetector::ResetOutcome outcome = detector.reset();
  EXPECT_EQ(outcome.kept_as, "");
  EXPECT_NE(outcome.problem.find("is gone"), std::string::npos) << outcome.problem;
  EXPECT_NE(outcome.problem.find("kept in memory only"), std::string::npos) << outcome.problem;
  EXPECT_TRUE(detector.database().empty());
  EXPECT_FALSE(std::filesystem::exists(folder)) << "nothing is created in its place";
  const FrameResult next = feed(&detector, 20, 20);
  EXPECT_FALSE(next.keyframe->error);
  EXPECT_EQ(detector.database().size(), 1u);  // Searched in memory.
}

TEST(LoopDetector, AMapKeepsItsSearchGraphAndLinksInWhatACrashLeftOut) {
  const std::string path = temporaryPath("graph_map.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.database.index.type = "approximate";
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 12; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    EXPECT_TRUE(detector.mapGraphReused());
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), 12u);
    feed(&detector, 12, 12);  // Then stopped without saving the graph, as a crash would.
  }
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  // The saved graph misses the last keyframe: reused, and the keyframe linked in.
  EXPECT_TRUE(detector.mapGraphReused());
  ASSERT_NE(detector.database().graph(), nullptr);
  EXPECT_EQ(detector.database().graph()->size(), 13u);
  removeMap(path);
}

TEST(LoopDetector, PastTheMemoryBudgetAMapKeepsGrowingOnDiskAndItsNextStartSearchesABudgetsWorth) {
  const std::string probe_path = temporaryPath("budget_probe.db");
  const std::string path = temporaryPath("budget_map.db");
  removeMap(probe_path);
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.database.index.type = "approximate";
  uint64_t last_written = 0;
  {
    LoopDetector probe(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(probe.openMap(probe_path), "");
    for (int i = 0; i < 40; ++i) feed(&probe, i, i);
    options.database.memory_budget_mb = static_cast<double>(probe.database().bytes()) / 1e6;
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 40; ++i) {
      const KeyframeResult stored = *feed(&detector, i, i).keyframe;
      EXPECT_TRUE(stored.stored && !stored.written_not_searched) << i;
    }
    ASSERT_TRUE(detector.overMemoryBudget());
    // Revisits still close loops; the keyframes go to the map, not to search.
    FrameResult last;
    for (int i = 40; i < 45; ++i) {
      last = feed(&detector, i, i - 30);
      EXPECT_TRUE(last.keyframe->stored && last.keyframe->written_not_searched) << i;
      EXPECT_TRUE(last.keyframe->store_error.empty()) << last.keyframe->store_error;
    }
    last_written = last.keyframe->keyframe_id;
    ASSERT_TRUE(last.keyframe->loop);
    EXPECT_EQ(last.keyframe->loop->match_id, 14u);
    EXPECT_EQ(detector.database().size(), 40u);
    EXPECT_EQ(detector.saveMapGraph(), "") << "the graph over the searched keyframes is saved";
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), 45u);
  // Without a budget the next start searches the whole map.
  {
    LoopDetectorOptions unbounded_options = options;
    unbounded_options.database.memory_budget_mb = 0.0;
    LoopDetector unbounded(unbounded_options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(unbounded.openMap(path), "");
    EXPECT_EQ(unbounded.database().size(), 45u);
    EXPECT_EQ(unbounded.mapKeyframesNotSearched(), 0u);
  }
  // With one, what fits it by the database's own account of a keyframe (rows, summary, links;
  // bench/README.md compares it with what a 1 000 000-keyframe map takes): the map's first
  // keyframes. The rest stay in the map, and new keyframes follow its last id and session.
  const double per_keyframe = static_cast<double>(
      KeyframeDatabase(256, options.database.index)  // PlaceExtractor's dimension.
          .bytesPerKeyframe(KeyframeStore::openExisting(path)->rowStride()));
  options.database.memory_budget_mb = per_keyframe * 30.5 / 1e6;
  {
    // The graph saved at shutdown covers 40: used whole rather than built again over 30.
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    EXPECT_EQ(detector.database().size(), 40u);
    EXPECT_EQ(detector.mapKeyframesNotSearched(), 5u);
    EXPECT_TRUE(detector.mapGraphReused());
  }
  std::filesystem::remove(path + "-graph");
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    const size_t searched = detector.database().size();
    EXPECT_EQ(searched, 30u);
    EXPECT_EQ(detector.mapKeyframesNotSearched(), 15u);
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), searched);
    EXPECT_EQ(detector.database().summary(searched - 1).id, searched - 1);
    EXPECT_EQ(detector.session(), 1u);
    const KeyframeResult next = *feed(&detector, 45, 45).keyframe;
    EXPECT_GT(next.keyframe_id, last_written);
    EXPECT_TRUE(next.stored && next.written_not_searched && next.store_error.empty())
        << next.store_error;
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), 46u);
  removeMap(probe_path);
  removeMap(path);
}

std::string fileBytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
}

// Waits for the map's integrity check (a thread of its own).
std::string settledMapCheck(const LoopDetector& detector) {
  for (int wait = 0; wait < 1000 && detector.mapCheck() == "being checked"; ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return detector.mapCheck();
}

// A map of `keyframes` keyframes (places i % places), closed cleanly.
void writeDetectorMap(const std::string& path, int keyframes, int places) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  for (int i = 0; i < keyframes; ++i) feed(&detector, i, i % places);
  EXPECT_EQ(detector.saveMapGraph(), "");
}

TEST(LoopDetector, AMapWhoseSealedRowsTurnOutDamagedStopsSearchAndIsNeverWrittenTo) {
  const std::string path = temporaryPath("damaged_rows_map.db");
  removeMap(path);
  const LoopDetectorOptions options = smallOptions();
  writeDetectorMap(path, 20, 20);
  const auto flipFirstRowByte = [](const std::string& map) {
    std::fstream rows(map + "-vectors", std::ios::in | std::ios::out | std::ios::binary);
    rows.seekg(30);
    const char byte = static_cast<char>(rows.get());
    rows.seekp(30);
    rows.put(static_cast<char>(byte ^ 0x5a));
  };
  flipFirstRowByte(path);
  const std::string damaged_map = fileBytes(path);
  const std::string damaged_rows = fileBytes(path + "-vectors");
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "") << "search starts while the map is checked";
  EXPECT_EQ(detector.database().size(), 20u);
  ASSERT_EQ(settledMapCheck(detector), "damaged");
  // Revisits of places 5..9: nothing searched, no loop, said once; kept in memory, not written.
  for (int i = 20; i < 25; ++i) {
    const KeyframeResult result = *feed(&detector, i, i - 15).keyframe;
    EXPECT_EQ(result.query_status, QueryStatus::kMapDamaged) << i;
    EXPECT_FALSE(result.loop) << i;
    EXPECT_TRUE(result.candidates.empty()) << i;
    EXPECT_TRUE(result.stored && result.store_error.empty()) << i;
    if (i == 20) {
      EXPECT_NE(result.map_damage.find("-vectors are damaged"), std::string::npos)
          << result.map_damage;
    } else {
      EXPECT_EQ(result.map_damage, "") << i;
    }
  }
  EXPECT_EQ(detector.database().size(), 25u);
  EXPECT_NE(detector.mapDamage(), "");
  // What a stop says: the file's 20, and the 5 of this run only in memory.
  EXPECT_EQ(detector.mapKeyframesInFile(), 20u);
  EXPECT_EQ(detector.mapKeyframesNotWritten(), 5u);
  EXPECT_NE(detector.saveMapGraph(), "") << "nothing is saved beside a damaged map";
  EXPECT_TRUE(fileBytes(path) == damaged_map);
  EXPECT_TRUE(fileBytes(path + "-vectors") == damaged_rows);
  const LoopDetector::ResetOutcome outcome = detector.reset();  // A fresh map: searched again.
  EXPECT_EQ(outcome.problem, "");
  EXPECT_EQ(detector.mapDamage(), "");
  EXPECT_EQ(detector.mapKeyframesNotWritten(), 0u);
  EXPECT_EQ(detector.mapCheck(), "checked");
  // The damaged map, kept aside by the reset, is as it was: its byte put back, it holds its 20.
  ASSERT_EQ(outcome.kept_as.rfind(path, 0), 0u) << outcome.kept_as;
  const std::string kept = outcome.kept_as;
  EXPECT_TRUE(fileBytes(kept) == damaged_map);
  EXPECT_TRUE(fileBytes(kept + "-vectors") == damaged_rows);
  flipFirstRowByte(kept);
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 20u);
  removeMap(path);
  removeMap(kept);
}

TEST(LoopDetector, AMapWithADamagedPageIsReportedAndNeverWrittenTo) {
  const std::string path = temporaryPath("damaged_page_map.db");
  removeMap(path);
  const LoopDetectorOptions options = smallOptions();
  writeDetectorMap(path, 60, 30);
  ASSERT_TRUE(test_support::turnOverMiddlePage(path));
  const std::string damaged_map = fileBytes(path);
  const std::string damaged_rows = fileBytes(path + "-vectors");
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    ASSERT_EQ(settledMapCheck(detector), "damaged");
    const KeyframeResult result = *feed(&detector, 60, 5).keyframe;
    EXPECT_NE(result.map_damage.find("map " + path + ": its pages are damaged"), std::string::npos)
        << result.map_damage;
    EXPECT_EQ(result.query_status, QueryStatus::kMapDamaged);
    EXPECT_TRUE(result.stored && result.store_error.empty());
    feed(&detector, 61, 6);
    EXPECT_NE(detector.saveDatabase(temporaryPath("damaged_page_copy.db")), "");
    EXPECT_FALSE(std::filesystem::exists(temporaryPath("damaged_page_copy.db")));
  }
  EXPECT_TRUE(fileBytes(path) == damaged_map) << "a damaged map is left as it was";
  EXPECT_TRUE(fileBytes(path + "-vectors") == damaged_rows);
  removeMap(path);
}

TEST(LoopDetector, KeyframesAddedWhileTheMapIsCheckedAreCommittedOnceItPasses) {
  const std::string path = temporaryPath("checked_map.db");
  removeMap(path);
  const LoopDetectorOptions options = smallOptions();
  writeDetectorMap(path, 20, 20);
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    // Whether or not the check has ended by then, every keyframe reaches the map.
    for (int i = 20; i < 23; ++i) {
      const KeyframeResult result = *feed(&detector, i, i - 15).keyframe;
      EXPECT_TRUE(result.stored && result.store_error.empty()) << i;
    }
    ASSERT_EQ(settledMapCheck(detector), "checked");
    feed(&detector, 23, 8);
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), 24u);
  removeMap(path);
}

// The node's save: the map copied a few pages at a time while keyframes go on between the steps;
// a reset (or load) between steps abandons the copy and leaves no file behind.
TEST(LoopDetector, ASaveInStepsTakesKeyframesAddedMeanwhileAndAResetAbandonsIt) {
  const std::string path = temporaryPath("stepped_save.lcdb");
  const std::string copy = temporaryPath("stepped_save_copy.lcdb");
  removeMap(path);
  removeMap(copy);
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  int next = 0;
  for (; next < 30; ++next) feed(&detector, next, next);
  std::string kept;
  ASSERT_EQ(detector.beginSave(copy, false, &kept), "");
  EXPECT_FALSE(std::filesystem::exists(copy));
  int steps = 0;
  bool done = false;
  while (!done && steps < 100000) {
    done = detector.continueSave(1);  // One 2 KB page per step.
    if (!done) feed(&detector, next, next), ++next, ++steps;
    EXPECT_FALSE(std::filesystem::exists(copy)) << "the copy appears whole or not at all";
  }
  ASSERT_TRUE(done);
  EXPECT_GT(next, 35) << "keyframes went on between the steps (" << steps << " steps)";
  std::unique_ptr<MapCopy> finishing = detector.takeSave();
  ASSERT_TRUE(finishing);
  feed(&detector, next, next), ++next;  // The copy no longer needs the detector.
  finishing->finish();
  EXPECT_EQ(finishing->keyframes(), static_cast<size_t>(next - 1));
  {
    auto copied = KeyframeStore::openExisting(copy);
    EXPECT_EQ(copied->size(), static_cast<size_t>(next - 1)) << "each keyframe stored meanwhile";
    EXPECT_NE(copied->mapId(), detector.mapId());
  }

  removeMap(copy);
  ASSERT_EQ(detector.beginSave(copy, false, nullptr), "");
  EXPECT_FALSE(detector.continueSave(1));
  const LoopDetector::ResetOutcome outcome = detector.reset();
  EXPECT_THROW(detector.continueSave(1), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(copy));
  EXPECT_FALSE(std::filesystem::exists(copy + ".partial"));
  EXPECT_TRUE(detector.continueSave(1)) << "said once; nothing is being saved now";
  removeMap(path);
  removeMap(outcome.kept_as);
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
    ASSERT_EQ(earlier.openMap(path), "");
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
      detector.announceKeyframes(true);
      if (!detector.openMap(path).empty()) _exit(2);
      const int first =
          static_cast<int>(detector.database().summary(detector.database().size() - 1).id) + 1;
      for (int i = first; i <= killed_after + first - 20; ++i) {
        feed(&detector, i, i - 15);
        for (const AnnouncedKeyframe& keyframe : detector.takeAnnounced()) {
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

  // Localising stores nothing: announced at once, its id reserved.
  LoopDetector localising(options, std::make_shared<PlaceExtractor>());
  localising.announceKeyframes(true);
  ASSERT_EQ(localising.openMap(path), "");
  localising.setMode(DetectorMode::kLocalization);
  const FrameResult result = feed(&localising, 100, 3);
  ASSERT_TRUE(result.keyframe);
  const std::vector<AnnouncedKeyframe> localised = localising.takeAnnounced();
  ASSERT_EQ(localised.size(), 1u);
  EXPECT_EQ(localised[0].summary.id, result.keyframe->keyframe_id);
  EXPECT_EQ(localised[0].map_id, localising.mapId());
  removeMap(path);
}

// The node publishes a loaded keyframe's stamp from its map: the camera's to the nanosecond.
TEST(LoopDetector, ALoadedKeyframeKeepsItsStampToTheNanosecond) {
  const std::string path = temporaryPath("exact_stamps.db");
  removeMap(path);
  const int64_t first_ns = 1700000000123456789;
  {
    LoopDetector mapped(smallOptions(), std::make_shared<PlaceExtractor>());
    ASSERT_EQ(mapped.openMap(path), "");
    for (int i = 0; i < 3; ++i) {
      const int64_t stamp_ns = first_ns + i * 1000000001LL;
      const double stamp = static_cast<double>(stamp_ns) * 1e-9;
      const FrameAdmission admission =
          mapped.admit(stamp, planarPose(i, 0, 0), place(i).cols, place(i).rows, place(i).type());
      ASSERT_TRUE(admission.isKeyframe());
      mapped.addKeyframe(admission.keyframe_id, stamp, planarPose(i, 0, 0), place(i), {}, {},
                         stamp_ns);
    }
    EXPECT_EQ(mapped.keyframeStampNs(2), first_ns + 2000000002LL) << "this run's, from memory";
  }
  LoopDetector loaded(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(loaded.openMap(path), "");
  for (uint64_t id = 0; id < 3; ++id) {
    ASSERT_TRUE(loaded.keyframeStampNs(id)) << id;
    EXPECT_EQ(*loaded.keyframeStampNs(id), first_ns + static_cast<int64_t>(id) * 1000000001LL);
  }
  EXPECT_FALSE(loaded.keyframeStampNs(7));
  removeMap(path);
}

// Issue 67 point 6: a large map without its saved graph (a crash, a deleted PATH-graph) was
// linked into a new graph inside the open, about 2 ms a keyframe, holding a nodelet manager's
// thread at start. Past MapReadSettings::graph_rows_built_inline it is built in the background:
// the open returns with exact search, loops are found meanwhile, and the graph is swapped in.
TEST(LoopDetector, AMapWithoutItsGraphIsSearchedExactlyWhileTheGraphBuildsInTheBackground) {
  const std::string path = temporaryPath("background_graph.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.database.index.type = "approximate";
  options.odometry_gate.enabled = true;
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 40; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  std::filesystem::remove(path + "-graph");

  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    MapReadSettings settings = detector.mapReadSettings();
    settings.graph_rows_built_inline = 10;
    ReadMap map = readMap(path, settings);
    ASSERT_NE(map.graph_build, nullptr) << "40 keyframes to link, more than 10";
    EXPECT_EQ(map.database.graph(), nullptr) << "exact search until it is ready";
    ASSERT_EQ(detector.adoptMap(std::move(map)), "");
    EXPECT_TRUE(detector.mapGraphBuilding());
    std::optional<AcceptedLoop> loop;
    for (int i = 0; i < 3; ++i) {
      const FrameResult result =
          detector.process(100000.0 + i, planarPose(500.0 + i, 0, 0), place(37 + i));
      ASSERT_TRUE(result.keyframe);
      if (result.keyframe->loop) loop = result.keyframe->loop;
    }
    ASSERT_TRUE(loop) << "found while (or after) the graph was built";
    EXPECT_EQ(loop->match_id, 39u);
    detector.awaitMapGraph();
    EXPECT_FALSE(detector.mapGraphBuilding());
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), detector.database().size())
        << "the keyframes added meanwhile are linked in too";
    EXPECT_EQ(detector.database().size(), 43u);

    // Saved at the stop: the next open reads it and builds nothing.
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  LoopDetector next(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next.openMap(path), "");
  EXPECT_FALSE(next.mapGraphBuilding());
  EXPECT_TRUE(next.mapGraphReused());
  removeMap(path);
}
