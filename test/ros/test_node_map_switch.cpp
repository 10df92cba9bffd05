// Save, load and reset while frames stream, as an operator calls them on a moving robot: every
// service answers, a map loaded mid-run keeps its keyframe ids under its own map_id, so that
// (map_id, id) never repeats, and every map file holds exactly the keyframes published for it.
#include <algorithm>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <future>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/DatabaseFile.h"
#include "landmark_loop_closure/ResetDatabase.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

void removeMapFiles(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
}

// The ids of the keyframes a map file holds.
std::set<uint64_t> idsInMap(const std::string& path) {
  std::set<uint64_t> ids;
  KeyframeStore::openExisting(path)->forEach(
      [&ids](KeyframeRecord keyframe) { ids.insert(keyframe.id); });
  return ids;
}

// A service called on its own thread while the caller goes on publishing frames.
template <typename Service>
std::future<std::pair<bool, Service>> callLater(const std::string& name, Service service) {
  return std::async(std::launch::async, [name, service]() mutable {
    const bool called = ros::service::call(name, service);
    return std::make_pair(called, service);
  });
}

}  // namespace

TEST(LoopClosureNode, SaveLoadAndResetWhileFramesStreamKeepEveryKeyframeNamedOnce) {
  std::string path;
  ASSERT_TRUE(ros::param::get("/loop_closure/database_path", path));
  const std::string copy = path + ".copy";
  removeMapFiles(copy);
  // What the node of an earlier run wrote beside its map at shutdown, after that run's cleanup.
  const std::filesystem::path own(path);
  for (const auto& entry : std::filesystem::directory_iterator(own.parent_path())) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("lcd_node_map_switch_", 0) == 0 && name.rfind(own.filename().string(), 0) != 0) {
      std::filesystem::remove(entry.path());
    }
  }
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  ASSERT_TRUE(ros::service::waitForService("/loop_closure/reset", ros::Duration(10.0)));

  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 2.0;
  options.start_stamp = 1700000000.0;
  SequenceGenerator sequence(world, CameraModel{}, options);
  ros::WallRate rate(test_support::kPublishRateHz);
  std::future<std::pair<bool, DatabaseFile>> save;
  std::future<std::pair<bool, DatabaseFile>> load;
  std::future<std::pair<bool, ResetDatabase>> reset;
  size_t second_lap_frames = 0;
  size_t load_answered_at = 0;  // The second-lap frame at which the load had answered.
  size_t keyframes_before_save = 0;
  std::set<uint64_t> in_copy;
  // From frame 10 of the second lap frames go out as fast as they can, faster than the worker
  // describes them, the load is asked for at frame 35 and the burst lasts until it answers: the
  // worker still has keyframes queued against the first map when the load switches maps. The
  // burst's frames are rendered before it starts, so that it outruns the worker however busy the
  // machine is (rendered as they went, a busy machine's worker once emptied its queue before the
  // load switched maps). It runs at most kBurstLead seconds of the sequence ahead of the newest
  // keyframe published: about 7 keyframes, so the worker's queue (8) stays full but never
  // overflows, and the images waiting for their odometry stay under sync_queue_size (30); sent
  // unbounded, the node's image queue overflowed and the gaps read as odometry jumps.
  constexpr size_t kBurstStart = 10, kBurstEnd = 35;
  constexpr double kBurstLead = 2.0;
  const auto wait_for_worker = [&](double stamp) {
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(1.0);
    while (ros::ok() && ros::WallTime::now() < give_up) {
      const auto& keyframes = harness.publishedKeyframes();
      if (keyframes.empty() || stamp - keyframes.back().header.stamp.toSec() <= kBurstLead) return;
      ros::WallDuration(0.002).sleep();
      ros::spinOnce();
    }
  };
  bool in_burst = false;
  constexpr size_t kRenderedAhead = 400;  // Frames rendered before the burst (about 30 MB).
  std::deque<SequenceFrame> rendered;
  const auto next_frame = [&](SequenceFrame* next) {
    if (rendered.empty()) return sequence.next(next);
    *next = std::move(rendered.front());
    rendered.pop_front();
    return true;
  };
  // The reset comes this many paced frames after the load answered, however long the load took
  // on a busy machine, so that the second lap has time to close loops into the loaded copy.
  constexpr size_t kLoadedFrames = 265;
  SequenceFrame frame;
  while (ros::ok() && next_frame(&frame)) {
    if (in_burst) wait_for_worker(frame.stamp);
    harness.publish(frame.stamp, frame.odom, frame.image);
    ros::spinOnce();
    const bool loading =
        load.valid() && load.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
    in_burst = frame.lap > 0 &&
               ((second_lap_frames >= kBurstStart && second_lap_frames + 1 < kBurstEnd) || loading);
    if (!in_burst) rate.sleep();
    if (frame.lap == 0) continue;
    // The first lap's map is copied as the second lap starts, the copy loaded a moment later (a
    // map of the same place, stored with the ids already published), and the map reset later.
    if (second_lap_frames == 0) {
      keyframes_before_save = harness.publishedKeyframes().size();
      DatabaseFile request;
      request.request.path = copy;
      save = callLater("/loop_closure/save_database", request);
    } else if (second_lap_frames + 1 == kBurstStart) {
      ASSERT_EQ(save.wait_for(std::chrono::seconds(30)), std::future_status::ready);
      in_copy = idsInMap(copy);  // Read before the node opens it (one process per map).
      SequenceFrame ahead;
      while (rendered.size() < kRenderedAhead && sequence.next(&ahead)) {
        rendered.push_back(std::move(ahead));
      }
    } else if (second_lap_frames + 1 == kBurstEnd) {
      DatabaseFile request;
      request.request.path = copy;
      load = callLater("/loop_closure/load_database", request);
    } else if (load.valid() && !loading && load_answered_at == 0) {
      load_answered_at = second_lap_frames;
    } else if (load_answered_at > 0 && second_lap_frames == load_answered_at + kLoadedFrames) {
      reset = callLater("/loop_closure/reset", ResetDatabase());
    }
    ++second_lap_frames;
  }
  harness.waitUntilQuiet();
  ASSERT_TRUE(save.valid() && load.valid() && reset.valid()) << "the second lap was too short";
  const auto [saved, save_answer] = save.get();
  const auto [loaded, load_answer] = load.get();
  const auto [was_reset, reset_answer] = reset.get();
  ASSERT_TRUE(saved && loaded && was_reset);
  EXPECT_TRUE(save_answer.response.success) << save_answer.response.message;
  EXPECT_TRUE(load_answer.response.success) << load_answer.response.message;
  EXPECT_TRUE(reset_answer.response.success) << reset_answer.response.message;
  // The keyframes queued against the first map when the copy replaced it are dropped, said in
  // the answer, and neither stored nor published (the maps' contents below).
  EXPECT_NE(load_answer.response.message.find("queued before the load dropped"), std::string::npos)
      << load_answer.response.message;
  std::printf("save: %s\nload: %s\nreset: %s\n", save_answer.response.message.c_str(),
              load_answer.response.message.c_str(), reset_answer.response.message.c_str());

  // Three maps, in turn: the first lap's, the copy loaded, the one the reset started.
  std::vector<uint64_t> maps;
  std::map<uint64_t, std::set<uint64_t>> published;  // Keyframe ids by map.
  std::set<std::pair<uint64_t, uint64_t>> names;
  for (const Keyframe& keyframe : harness.publishedKeyframes()) {
    if (maps.empty() || maps.back() != keyframe.map_id) maps.push_back(keyframe.map_id);
    EXPECT_TRUE(names.insert({keyframe.map_id, keyframe.id}).second)
        << "(map " << keyframe.map_id << ", keyframe " << keyframe.id << ") published twice";
    published[keyframe.map_id].insert(keyframe.id);
  }
  ASSERT_EQ(maps.size(), 3u) << "each map is named by one map_id, and none comes back";
  EXPECT_EQ(std::set<uint64_t>(maps.begin(), maps.end()).size(), 3u);
  const uint64_t first_map = maps[0], loaded_map = maps[1], reset_map = maps[2];
  EXPECT_GT(keyframes_before_save, 150u);

  // The copy holds first-lap keyframes under the ids they were published with; the loaded map's
  // new keyframes never take an id published before.
  EXPECT_GE(in_copy.size(), keyframes_before_save);
  EXPECT_TRUE(std::includes(published[first_map].begin(), published[first_map].end(),
                            in_copy.begin(), in_copy.end()));
  EXPECT_GT(*published[loaded_map].begin(), *published[first_map].rbegin());
  EXPECT_GT(*published[reset_map].begin(), *published[loaded_map].rbegin());

  // Each map file holds what was published for it (and the copy's keyframes, once loaded).
  EXPECT_EQ(idsInMap(path), published[first_map]) << "the first lap's map, closed by the load";
  const std::string kept_prefix = "the earlier map is kept as ";
  const size_t kept_at = reset_answer.response.message.find(kept_prefix);
  ASSERT_NE(kept_at, std::string::npos) << reset_answer.response.message;
  std::string kept = reset_answer.response.message.substr(kept_at + kept_prefix.size());
  kept = kept.substr(0, kept.find(';'));
  std::set<uint64_t> expected_kept = in_copy;
  expected_kept.insert(published[loaded_map].begin(), published[loaded_map].end());
  EXPECT_EQ(idsInMap(kept), expected_kept) << kept;

  // Loops name keyframes by (map_id, id): the query is published, the match is too or comes
  // from the loaded copy; after the load the second lap closes loops into the copy.
  size_t loops_into_copy = 0;
  for (const LoopClosure& loop : harness.loops()) {
    SCOPED_TRACE("loop " + std::to_string(loop.query_id) + " -> " + std::to_string(loop.match_id));
    EXPECT_TRUE(names.count({loop.map_id, loop.query_id}));
    if (loop.map_id == loaded_map && in_copy.count(loop.match_id)) {
      EXPECT_LT(loop.match_session, loop.query_session);
      ++loops_into_copy;
    } else {
      EXPECT_TRUE(names.count({loop.map_id, loop.match_id}));
    }
  }
  std::printf(
      "keyframes published: %zu in the first map, %zu in the loaded copy (which held %zu), "
      "%zu after the reset; %zu loops, %zu into the copy\n",
      published[first_map].size(), published[loaded_map].size(), in_copy.size(),
      published[reset_map].size(), harness.loops().size(), loops_into_copy);
  EXPECT_GT(loops_into_copy, 10u);

  removeMapFiles(copy);
  removeMapFiles(kept);
  removeMapFiles(path);  // The node holds it open: its files go when it stops.
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_map_switch");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
