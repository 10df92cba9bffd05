// The detector with a map file: sessions, the map kept on disk as keyframes come, its search
// graph, the memory budget at open and a damaged rows file found while search runs.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <thread>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/loop_detector.h"
#include "map_damage.h"
#include "map_files.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::place;
using test_support::PlaceExtractor;

using test_support::feed;
using test_support::removeMap;
using test_support::smallOptions;
using test_support::temporaryPath;

TEST(LoopDetector, ASavedMapIsRecognisedInTheNextSession) {
  const std::string path = temporaryPath("saved_map.lcdb");
  removeMap(path);  // A save never replaces a file: start from none.
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  {
    LoopDetector first_run(options, std::make_shared<PlaceExtractor>());
    for (int i = 0; i < 40; ++i) feed(&first_run, i, i);
    ASSERT_EQ(first_run.map().save(path), "");
  }
  // The next day: the odometry starts again at another origin, stamps go on.
  LoopDetector next_run(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next_run.map().load(path), "");
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

TEST(LoopDetector, ARefusedLoadChangesNothingAndResetForgetsAll) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  const std::string error = detector.map().load(temporaryPath("missing.lcdb"));
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
    ASSERT_EQ(other.map().save(path), "");
  }
  const std::string refused = detector.map().load(path);
  EXPECT_NE(refused.find("other descriptors"), std::string::npos) << refused;
  EXPECT_NE(refused.find("type is hog in the map"), std::string::npos) << "names what differs";
  EXPECT_EQ(detector.database().size(), 12u);
  removeMap(path);

  detector.map().reset();
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
    ASSERT_EQ(detector.map().open(path), "");
    EXPECT_EQ(detector.map().path(), path);
    for (int i = 0; i < 15; ++i) feed(&detector, i, i);
  }  // No save: every keyframe was committed when it was stored.
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.map().open(path), "");
  EXPECT_EQ(detector.database().size(), 15u);
  EXPECT_EQ(detector.session(), 1u);

  const MapSession::ResetOutcome outcome = detector.map().reset();
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
    ASSERT_EQ(detector.map().save(saved), "");
    EXPECT_EQ(detector.database().size(), 3u);
  }
  EXPECT_EQ(KeyframeStore::openExisting(saved)->size(), 3u);
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.map().open(open), "");
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
  ASSERT_EQ(detector.map().open(path), "");
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  // The map's folder is deleted under the running detector (a cleanup script, a full disk).
  std::filesystem::remove_all(folder);
  const MapSession::ResetOutcome outcome = detector.map().reset();
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
    ASSERT_EQ(detector.map().open(path), "");
    for (int i = 0; i < 12; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.map().saveGraph(), "");
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.map().open(path), "");
    EXPECT_TRUE(detector.map().graphReused());
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), 12u);
    feed(&detector, 12, 12);  // Then stopped without saving the graph, as a crash would.
  }
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.map().open(path), "");
  // The saved graph misses the last keyframe: reused, and the keyframe linked in.
  EXPECT_TRUE(detector.map().graphReused());
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
    ASSERT_EQ(probe.map().open(probe_path), "");
    for (int i = 0; i < 40; ++i) feed(&probe, i, i);
    options.database.memory_budget_mb = static_cast<double>(probe.database().bytes()) / 1e6;
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.map().open(path), "");
    for (int i = 0; i < 40; ++i) {
      const KeyframeResult stored = *feed(&detector, i, i).keyframe;
      EXPECT_TRUE(stored.stored && !stored.written_not_searched) << i;
    }
    ASSERT_TRUE(detector.map().overMemoryBudget());
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
    EXPECT_EQ(detector.map().saveGraph(), "") << "the graph over the searched keyframes is saved";
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), 45u);
  // Without a budget the next start searches the whole map.
  {
    LoopDetectorOptions unbounded_options = options;
    unbounded_options.database.memory_budget_mb = 0.0;
    LoopDetector unbounded(unbounded_options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(unbounded.map().open(path), "");
    EXPECT_EQ(unbounded.database().size(), 45u);
    EXPECT_EQ(unbounded.map().keyframesNotSearched(), 0u);
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
    ASSERT_EQ(detector.map().open(path), "");
    EXPECT_EQ(detector.database().size(), 40u);
    EXPECT_EQ(detector.map().keyframesNotSearched(), 5u);
    EXPECT_TRUE(detector.map().graphReused());
  }
  std::filesystem::remove(path + "-graph");
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.map().open(path), "");
    const size_t searched = detector.database().size();
    EXPECT_EQ(searched, 30u);
    EXPECT_EQ(detector.map().keyframesNotSearched(), 15u);
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), searched);
    EXPECT_EQ(detector.database().summary(searched - 1).id, searched - 1);
    EXPECT_EQ(detector.session(), 1u);
    const KeyframeResult next = *feed(&detector, 45, 45).keyframe;
    EXPECT_GT(next.keyframe_id, last_written);
    EXPECT_TRUE(next.stored && next.written_not_searched && next.store_error.empty())
        << next.store_error;
    EXPECT_EQ(detector.map().saveGraph(), "");
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
  for (int wait = 0; wait < 1000 && detector.map().check() == "being checked"; ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return detector.map().check();
}

// A map of `keyframes` keyframes (places i % places), closed cleanly.
void writeDetectorMap(const std::string& path, int keyframes, int places) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.map().open(path), "");
  for (int i = 0; i < keyframes; ++i) feed(&detector, i, i % places);
  EXPECT_EQ(detector.map().saveGraph(), "");
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
  ASSERT_EQ(detector.map().open(path), "") << "search starts while the map is checked";
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
  EXPECT_NE(detector.map().damage(), "");
  // What a stop says: the file's 20, and the 5 of this run only in memory.
  EXPECT_EQ(detector.map().keyframesInFile(), 20u);
  EXPECT_EQ(detector.map().keyframesNotWritten(), 5u);
  EXPECT_NE(detector.map().saveGraph(), "") << "nothing is saved beside a damaged map";
  EXPECT_TRUE(fileBytes(path) == damaged_map);
  EXPECT_TRUE(fileBytes(path + "-vectors") == damaged_rows);
  const MapSession::ResetOutcome outcome = detector.map().reset();  // A fresh map: searched again.
  EXPECT_EQ(outcome.problem, "");
  EXPECT_EQ(detector.map().damage(), "");
  EXPECT_EQ(detector.map().keyframesNotWritten(), 0u);
  EXPECT_EQ(detector.map().check(), "checked");
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
    ASSERT_EQ(detector.map().open(path), "");
    ASSERT_EQ(settledMapCheck(detector), "damaged");
    const KeyframeResult result = *feed(&detector, 60, 5).keyframe;
    EXPECT_NE(result.map_damage.find("map " + path + ": its pages are damaged"), std::string::npos)
        << result.map_damage;
    EXPECT_EQ(result.query_status, QueryStatus::kMapDamaged);
    EXPECT_TRUE(result.stored && result.store_error.empty());
    feed(&detector, 61, 6);
    EXPECT_NE(detector.map().save(temporaryPath("damaged_page_copy.db")), "");
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
    ASSERT_EQ(detector.map().open(path), "");
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
  ASSERT_EQ(detector.map().open(path), "");
  int next = 0;
  for (; next < 30; ++next) feed(&detector, next, next);
  std::string kept;
  ASSERT_EQ(detector.map().beginSave(copy, false, &kept), "");
  EXPECT_FALSE(std::filesystem::exists(copy));
  int steps = 0;
  bool done = false;
  while (!done && steps < 100000) {
    done = detector.map().continueSave(1);  // One 2 KB page per step.
    if (!done) feed(&detector, next, next), ++next, ++steps;
    EXPECT_FALSE(std::filesystem::exists(copy)) << "the copy appears whole or not at all";
  }
  ASSERT_TRUE(done);
  EXPECT_GT(next, 35) << "keyframes went on between the steps (" << steps << " steps)";
  std::unique_ptr<MapCopy> finishing = detector.map().takeSave();
  ASSERT_TRUE(finishing);
  feed(&detector, next, next), ++next;  // The copy no longer needs the detector.
  finishing->finish();
  EXPECT_EQ(finishing->keyframes(), static_cast<size_t>(next - 1));
  {
    auto copied = KeyframeStore::openExisting(copy);
    EXPECT_EQ(copied->size(), static_cast<size_t>(next - 1)) << "each keyframe stored meanwhile";
    EXPECT_NE(copied->mapId(), detector.map().mapId());
  }

  removeMap(copy);
  ASSERT_EQ(detector.map().beginSave(copy, false, nullptr), "");
  EXPECT_FALSE(detector.map().continueSave(1));
  const MapSession::ResetOutcome outcome = detector.map().reset();
  EXPECT_THROW(detector.map().continueSave(1), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(copy));
  EXPECT_FALSE(std::filesystem::exists(copy + ".partial"));
  EXPECT_TRUE(detector.map().continueSave(1)) << "said once; nothing is being saved now";
  removeMap(path);
  removeMap(outcome.kept_as);
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
    ASSERT_EQ(detector.map().open(path), "");
    for (int i = 0; i < 40; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.map().saveGraph(), "");
  }
  std::filesystem::remove(path + "-graph");

  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    MapReadSettings settings = detector.map().readSettings();
    settings.graph_rows_built_inline = 10;
    ReadMap map = readMap(path, settings);
    ASSERT_NE(map.graph_build, nullptr) << "40 keyframes to link, more than 10";
    EXPECT_EQ(map.database.graph(), nullptr) << "exact search until it is ready";
    ASSERT_EQ(detector.map().adopt(std::move(map)), "");
    EXPECT_TRUE(detector.map().graphBuilding());
    std::optional<AcceptedLoop> loop;
    for (int i = 0; i < 3; ++i) {
      const FrameResult result =
          detector.process(100000.0 + i, planarPose(500.0 + i, 0, 0), place(37 + i));
      ASSERT_TRUE(result.keyframe);
      if (result.keyframe->loop) loop = result.keyframe->loop;
    }
    ASSERT_TRUE(loop) << "found while (or after) the graph was built";
    EXPECT_EQ(loop->match_id, 39u);
    detector.map().awaitGraph();
    EXPECT_FALSE(detector.map().graphBuilding());
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), detector.database().size())
        << "the keyframes added meanwhile are linked in too";
    EXPECT_EQ(detector.database().size(), 43u);

    // Saved at the stop: the next open reads it and builds nothing.
    EXPECT_EQ(detector.map().saveGraph(), "");
  }
  LoopDetector next(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next.map().open(path), "");
  EXPECT_FALSE(next.map().graphBuilding());
  EXPECT_TRUE(next.map().graphReused());
  removeMap(path);
}
