// The promises a map keeps when the disk does not (issue 80): a keyframe is announced only once
// the file holds it, a full disk never makes an intact map "damaged", no (map id, keyframe id)
// goes out twice, and every run on a map is a session of its own. The disk fills through
// failing_disk.h, without a mount.
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "failing_disk.h"
#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "map_files.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::FailingDisk;
using test_support::PlaceExtractor;
using test_support::removeMap;
using test_support::smallOptions;
using test_support::temporaryPath;

namespace {

using Key = std::pair<uint64_t, uint64_t>;  // (map id, keyframe id), as a backend keys them.

// One run of the small detector on a map, announcing as the node does.
struct MapRun {
  explicit MapRun(const std::string& path, DetectorMode mode = DetectorMode::kMapping)
      : detector(smallOptions(), std::make_shared<PlaceExtractor>()) {
    opened = detector.map().open(path);
    detector.map().announceKeyframes(true);
    detector.setMode(mode);
  }
  // Frame `i`, 1 m on from the last, showing place i % 40 (so places come back every 40 m).
  FrameResult feed(int i) {
    FrameResult result = detector.process(i, planarPose(i, 0, 0), place(i % 40));
    if (result.keyframe && result.keyframe->loop) loops.push_back(*result.keyframe->loop);
    for (AnnouncedKeyframe& next : detector.map().takeAnnounced()) announced.push_back(next);
    return result;
  }
  static cv::Mat place(int value) { return test_support::place(value); }

  LoopDetector detector;
  std::string opened;
  std::vector<AnnouncedKeyframe> announced;
  std::vector<AcceptedLoop> loops;
};

std::set<Key> keysInFile(const std::string& path) {
  std::set<Key> keys;
  auto store = KeyframeStore::openExisting(path);  // Its integrity checked too.
  store->forEach([&](KeyframeRecord keyframe) { keys.insert({store->mapId(), keyframe.id}); });
  return keys;
}

}  // namespace

// Done-when: 2 000 frames, the disk full after 1 300 keyframes and with room again later; every
// keyframe announced is in the file, no loop names one that is not, diagnostics' problem is set
// while it lasts, and a later run gives no (map id, id) twice.
TEST(MapFullDisk, NoKeyframeIsAnnouncedThatTheFileLacksAndNoIdGoesOutTwice) {
  FailingDisk& disk = FailingDisk::instance();
  const std::string path = temporaryPath("full_disk.lcdb");
  removeMap(path);
  std::vector<AnnouncedKeyframe> announced;
  size_t refused = 0;
  {
    MapRun run(path);
    ASSERT_EQ(run.opened, "");
    for (int i = 0; i < 2000; ++i) {
      if (i == 1300) disk.fillAfter(0);
      if (i == 1700) disk.empty();
      const FrameResult result = run.feed(i);
      ASSERT_TRUE(result.keyframe) << i;
      if (disk.full()) {
        EXPECT_FALSE(result.keyframe->store_error.empty()) << i;
        EXPECT_FALSE(result.keyframe->stored) << i;
        EXPECT_FALSE(result.keyframe->loop) << i << ": its query keyframe is announced nowhere";
        EXPECT_NE(run.detector.map().writeProblem(), "") << i;
        ++refused;
      } else {
        EXPECT_EQ(result.keyframe->store_error, "") << i;
        EXPECT_EQ(run.detector.map().writeProblem(), "") << i << ": writes succeed again";
      }
    }
    EXPECT_EQ(refused, 400u);
    EXPECT_EQ(run.detector.map().keyframesNotWritten(), 400u);
    EXPECT_GT(run.loops.size(), 20u) << "places come back every 40 keyframes";
    std::set<uint64_t> announced_ids;
    for (const AnnouncedKeyframe& keyframe : run.announced)
      announced_ids.insert(keyframe.summary.id);
    for (const AcceptedLoop& loop : run.loops) {
      EXPECT_EQ(announced_ids.count(loop.query_id), 1u) << loop.query_id;
      EXPECT_EQ(announced_ids.count(loop.match_id), 1u) << loop.match_id;
    }
    announced = run.announced;
  }
  EXPECT_EQ(announced.size(), 1600u);
  {
    MapRun next(path);  // The next run on the map, with room.
    ASSERT_EQ(next.opened, "");
    for (int i = 2000; i < 2200; ++i) next.feed(i);
    announced.insert(announced.end(), next.announced.begin(), next.announced.end());
  }
  const std::set<Key> in_file = keysInFile(path);
  std::set<Key> seen;
  for (const AnnouncedKeyframe& keyframe : announced) {
    const Key key{keyframe.map_id, keyframe.summary.id};
    EXPECT_TRUE(seen.insert(key).second) << "keyframe " << key.second << " announced twice";
    EXPECT_EQ(in_file.count(key), 1u) << "keyframe " << key.second << " announced, not in the file";
  }
  EXPECT_EQ(in_file.size(), 1800u);
  removeMap(path);
}

// Done-when: started while the disk is full (the last run's close could not write its log back
// into the file), the map is not declared damaged; it is written to again once there is room.
TEST(MapFullDisk, AMapOpenedOnAFullDiskIsNotDamagedAndTakesKeyframesOnceThereIsRoom) {
  FailingDisk& disk = FailingDisk::instance();
  const std::string path = temporaryPath("full_at_start.lcdb");
  removeMap(path);
  {
    MapRun run(path);
    ASSERT_EQ(run.opened, "");
    for (int i = 0; i < 300; ++i) run.feed(i);
    disk.fillAfter(8192);  // The close's checkpoint writes a few pages, then the disk is full.
  }
  disk.fillAfter(0);
  std::set<uint64_t> announced_ids;
  {
    MapRun run(path);
    ASSERT_EQ(run.opened, "") << "opening reads; it needs no room";
    for (int i = 300; i < 320; ++i) {
      const FrameResult result = run.feed(i);
      ASSERT_TRUE(result.keyframe);
      EXPECT_NE(result.keyframe->store_error, "") << i;
      EXPECT_EQ(run.detector.map().damage(), "");
      EXPECT_NE(run.detector.map().check(), "damaged");
    }
    EXPECT_NE(run.detector.map().check().find("not checked yet"), std::string::npos)
        << run.detector.map().check();
    EXPECT_TRUE(run.announced.empty());
    disk.empty();
    // Tried again at most once a second: keyframes go on until the check has passed and the
    // file takes them.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    int i = 320;
    while (run.detector.map().check() != "checked" && std::chrono::steady_clock::now() < give_up) {
      run.feed(i++);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_EQ(run.detector.map().check(), "checked");
    const int first_after = i;
    for (; i < first_after + 20; ++i) {
      const FrameResult result = run.feed(i);
      EXPECT_EQ(result.keyframe->store_error, "") << i;
    }
    EXPECT_EQ(run.detector.map().damage(), "");
    EXPECT_EQ(run.detector.map().writeProblem(), "");
    for (const AnnouncedKeyframe& keyframe : run.announced)
      announced_ids.insert(keyframe.summary.id);
    EXPECT_GE(announced_ids.size(), 20u);
  }
  std::set<uint64_t> in_file;
  for (const Key& key : keysInFile(path)) in_file.insert(key.second);
  EXPECT_GE(in_file.size(), 320u);
  for (const uint64_t id : announced_ids) EXPECT_EQ(in_file.count(id), 1u) << id;
  removeMap(path);
}

// Done-when: five alternating mapping and localisation runs on one map are five sessions, and the
// pose graph keeps them as five chains, no odometry edge between two runs.
TEST(MapSessions, FiveAlternatingMappingAndLocalisationRunsAreFiveSessionsAndFiveChains) {
  FailingDisk::instance();
  const std::string path = temporaryPath("five_runs.lcdb");
  removeMap(path);
  std::vector<std::vector<AnnouncedKeyframe>> runs;
  for (int run_index = 0; run_index < 5; ++run_index) {
    MapRun run(path, run_index % 2 == 0 ? DetectorMode::kMapping : DetectorMode::kLocalization);
    ASSERT_EQ(run.opened, "");
    for (int i = 0; i < 90; ++i) run.feed(run_index * 90 + i);
    runs.push_back(run.announced);
  }
  PoseGraphSession graph(PoseGraphNodeOptions{}, [](const std::string&, std::string* problem) {
    *problem = "no mount in this test";
    return std::optional<Eigen::Isometry3d>();
  });
  std::set<uint32_t> sessions;
  for (size_t r = 0; r < runs.size(); ++r) {
    ASSERT_EQ(runs[r].size(), 90u) << "run " << r;
    std::set<uint32_t> of_run;
    std::vector<PoseGraphSession::Input> inputs;
    for (const AnnouncedKeyframe& keyframe : runs[r]) {
      of_run.insert(keyframe.summary.session);
      GraphKeyframe input;
      input.id = keyframe.summary.id;
      input.map_id = keyframe.map_id;
      input.session = keyframe.summary.session;
      input.odometry = keyframe.summary.pose;
      input.stamp_ns = static_cast<uint64_t>(keyframe.summary.stamp * 1e9) + 1;
      input.odometry_frame = "odom";
      inputs.emplace_back(input);
    }
    EXPECT_EQ(of_run.size(), 1u) << "run " << r << " is one session";
    sessions.insert(of_run.begin(), of_run.end());
    graph.process(inputs);
  }
  EXPECT_EQ(sessions, (std::set<uint32_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(graph.graph().chains(), 5u);
  std::set<size_t> chains;
  for (const std::vector<AnnouncedKeyframe>& run : runs) {
    std::set<size_t> of_run;
    for (const AnnouncedKeyframe& keyframe : run) {
      const std::optional<uint64_t> id = graph.graphId(keyframe.map_id, keyframe.summary.id);
      ASSERT_TRUE(id);
      of_run.insert(*graph.graph().chainOf(*id));
    }
    EXPECT_EQ(of_run.size(), 1u) << "one chain a run: no odometry edge joins two runs";
    chains.insert(of_run.begin(), of_run.end());
  }
  EXPECT_EQ(chains.size(), 5u);
  removeMap(path);
}
