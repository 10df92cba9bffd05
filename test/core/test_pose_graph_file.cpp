// The pose graph saved beside the map (issue 68): what entered the graph is written at stop (and
// every few seconds) and replayed by the next run's pose graph, whose new session then joins it;
// a damaged file is reported and never written to.
#include <unistd.h>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/backend/pose_graph_file.h"
#include "landmark_loop_closure/backend/pose_graph_runtime.h"

namespace landmark_loop_closure {
namespace {

constexpr uint64_t kMap = 7;
constexpr uint64_t kSecond = 1000000000ull;

/// Session `session`'s keyframe `id`, truly at x = place (1 m a keyframe), in an odometry frame
/// turned by `frame_yaw` about the origin.
GraphKeyframe keyframe(uint64_t id, uint32_t session, double place, double frame_yaw = 0.0) {
  GraphKeyframe made;
  made.id = id;
  made.map_id = kMap;
  made.session = session;
  made.odometry = Pose::fromIsometry(Eigen::AngleAxisd(frame_yaw, Eigen::Vector3d::UnitZ()) *
                                     Eigen::Translation3d(place, 0.0, 0.0));
  made.stamp_ns = (id + 1) * kSecond;
  made.odometry_frame = "odom";
  return made;
}

/// Keyframes `query` and `match` are at the same place.
GraphLoop samePlace(uint64_t query, uint32_t query_session, uint64_t match,
                    uint32_t match_session) {
  GraphLoop loop;
  loop.map_id = kMap;
  loop.query_session = query_session;
  loop.match_session = match_session;
  loop.has_relative_pose = loop.relative_pose_metric = true;
  loop.relative_pose_frame = "base_link";
  loop.constraint.query_id = query;
  loop.constraint.match_id = match;
  loop.constraint.covariance = 1e-4 * Eigen::Matrix<double, 6, 6>::Identity();
  return loop;
}

/// Run 1: session 0 drives x = 0..19. Run 2: session 1 (a new odometry frame, turned) drives
/// x = 0..9 again, with loops to run 1 at keyframes 24 and 26.
std::vector<PoseGraphSession::Input> firstRun() {
  std::vector<PoseGraphSession::Input> inputs;
  for (uint64_t id = 0; id < 20; ++id) inputs.emplace_back(keyframe(id, 0, double(id)));
  return inputs;
}

std::vector<PoseGraphSession::Input> secondRun() {
  std::vector<PoseGraphSession::Input> inputs;
  for (uint64_t id = 20; id < 30; ++id) {
    inputs.emplace_back(keyframe(id, 1, double(id - 20), M_PI / 2));
    if (id == 24 || id == 26) inputs.emplace_back(samePlace(id, 1, id - 20, 0));
  }
  return inputs;
}

class PoseGraphFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = std::filesystem::temp_directory_path() /
              ("pose_graph_file_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
    path_ = (folder_ / "map.db-pose_graph").string();
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }

  /// A runtime on path_ fed `inputs`, stopped once its graph holds `keyframes` (what it
  /// restored and `inputs`' own) and the last of `inputs`' keyframes; the lines it said about
  /// the file. (A restored graph may already be as large as the one awaited.)
  std::vector<std::string> run(const std::vector<PoseGraphSession::Input>& inputs, size_t keyframes,
                               std::string* summary = nullptr) {
    std::optional<std::pair<uint64_t, uint64_t>> last_keyframe;
    for (const PoseGraphSession::Input& input : inputs) {
      if (const auto* keyframe = std::get_if<GraphKeyframe>(&input)) {
        last_keyframe = {keyframe->map_id, keyframe->id};
      }
    }
    std::mutex mutex;
    std::condition_variable changed;
    bool entered = false;
    std::vector<std::string> lines;
    PoseGraphListener listener;
    listener.step = [&](PoseGraphSession& session, const GraphStep&) {
      std::lock_guard<std::mutex> lock(mutex);
      entered = session.graph().keyframes() >= keyframes &&
                (!last_keyframe || session.graphId(last_keyframe->first, last_keyframe->second));
      changed.notify_all();
    };
    listener.graph_file = [&](const std::string& text, bool problem) {
      std::lock_guard<std::mutex> lock(mutex);
      lines.push_back((problem ? "problem: " : "") + text);
    };
    PoseGraphNodeOptions options;
    options.graph_file = path_;
    PoseGraphRuntime runtime(options, MountLookup(), listener, std::chrono::milliseconds(20));
    for (const PoseGraphSession::Input& input : inputs) runtime.push(input);
    {
      std::unique_lock<std::mutex> lock(mutex);
      changed.wait_for(lock, std::chrono::seconds(20), [&] { return entered; });
    }
    runtime.stop();
    if (summary) *summary = runtime.summary();
    return lines;
  }

  std::filesystem::path folder_;
  std::string path_;
};

TEST_F(PoseGraphFileTest, EveryInputSurvivesTheFileAndTheReplayGivesTheSameGraph) {
  PoseGraphSession first(PoseGraphNodeOptions{}, MountLookup());
  std::vector<PoseGraphSession::Input> inputs = firstRun();
  for (const PoseGraphSession::Input& input : secondRun()) inputs.push_back(input);
  for (const PoseGraphSession::Input& input : inputs) first.process({input});
  ASSERT_EQ(first.graph().chainsJoinedToFirst(), 2u);
  ASSERT_EQ(first.kept().size(), inputs.size());
  ASSERT_EQ(saveGraphFile(path_, first.kept()), "");

  std::vector<PoseGraphSession::Input> read;
  ASSERT_EQ(readGraphFile(path_, &read), "");
  ASSERT_EQ(read.size(), inputs.size());
  PoseGraphSession restored(PoseGraphNodeOptions{}, MountLookup());
  const GraphStep step = restored.restore(read);
  EXPECT_TRUE(step.publish_paths);
  EXPECT_TRUE(step.verdicts.empty());  // Decisions made before are not announced again.
  EXPECT_EQ(restored.graph().keyframes(), 30u);
  EXPECT_EQ(restored.graph().chainsJoinedToFirst(), 2u);
  EXPECT_EQ(restored.graph().activeLoops(), 2u);
  for (uint64_t id = 0; id < 30; ++id) {
    EXPECT_TRUE(restored.optimisedPose(kMap, id)->position.isApprox(
        first.optimisedPose(kMap, id)->position, 1e-9))
        << id;
  }
  EXPECT_EQ(restored.stampsNs(), first.stampsNs());
}

// Run 1's pose graph saves at stop; run 2's restores it and its new session joins run 1's chain
// by its loops, instead of leaving them out (issue 68, Done-when line 1 with the node restarted).
TEST_F(PoseGraphFileTest, TheNextRunsGraphRestoresTheSavedOneAndJoinsItsSessionToIt) {
  const std::vector<std::string> first = run(firstRun(), 20);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0], "no saved graph at " + path_ + " yet: the graph starts empty");
  ASSERT_TRUE(std::filesystem::exists(path_));

  std::string summary;
  const std::vector<std::string> second = run(secondRun(), 30, &summary);
  ASSERT_GE(second.size(), 1u);
  EXPECT_EQ(second[0].find("restored 20 keyframes in 1 chain(s) (1 joined to the first) and 0 "
                           "loops from " +
                           path_),
            0u)
      << second[0];
  EXPECT_NE(summary.find("30 keyframes in 2 chain(s), 2 joined by loops to the first"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("accepted 2"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("left out"), std::string::npos) << summary;

  // A third start restores both runs.
  std::string third_summary;
  const std::vector<std::string> third = run({}, 30, &third_summary);
  ASSERT_GE(third.size(), 1u);
  EXPECT_NE(third[0].find("restored 30 keyframes in 2 chain(s) (2 joined to the first) and 2 "
                          "loops"),
            std::string::npos)
      << third[0];
}

// A bag played again into a detector on a new map: a new graph, as many inputs as the saved one
// held; it is still saved (the file follows the graph, not its size).
TEST_F(PoseGraphFileTest, ANewTimelineOfTheSameSizeIsSavedOverTheOld) {
  run(firstRun(), 20);
  std::vector<PoseGraphSession::Input> replayed;
  for (uint64_t id = 0; id < 20; ++id) {
    GraphKeyframe again = keyframe(id, 0, double(id));
    again.map_id = kMap + 1;
    again.stamp_ns = again.stamp_ns / 2;  // Before the saved graph's: time went back.
    replayed.emplace_back(again);
  }
  run(replayed, 20);
  std::vector<PoseGraphSession::Input> read;
  ASSERT_EQ(readGraphFile(path_, &read), "");
  ASSERT_EQ(read.size(), 20u);
  EXPECT_EQ(std::get<GraphKeyframe>(read.front()).map_id, kMap + 1);
}

TEST_F(PoseGraphFileTest, ADamagedFileIsReportedAndNeverWrittenTo) {
  run(firstRun(), 20);
  std::string bytes;
  {
    std::ifstream in(path_, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(bytes.size(), 200u);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5a);
  {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  std::vector<PoseGraphSession::Input> read;
  EXPECT_NE(readGraphFile(path_, &read).find("checksum mismatch"), std::string::npos);

  std::string summary;
  const std::vector<std::string> lines = run(secondRun(), 10, &summary);
  ASSERT_GE(lines.size(), 1u);
  EXPECT_EQ(lines[0].find("problem: the saved graph " + path_ + " cannot be used ("), 0u)
      << lines[0];
  EXPECT_NE(lines[0].find("left as it is, never written"), std::string::npos) << lines[0];
  EXPECT_NE(summary.find("10 keyframes"), std::string::npos) << summary;  // Run 2 alone.
  std::string after;
  {
    std::ifstream in(path_, std::ios::binary);
    after.assign(std::istreambuf_iterator<char>(in), {});
  }
  EXPECT_EQ(after, bytes);
}

TEST_F(PoseGraphFileTest, OtherFilesAreNotTakenForAGraph) {
  std::vector<PoseGraphSession::Input> read;
  { std::ofstream(path_) << "a text file, not a pose graph, long enough to hold a header"; }
  EXPECT_NE(readGraphFile(path_, &read).find("not a pose graph file"), std::string::npos)
      << readGraphFile(path_, &read);
  EXPECT_NE(readGraphFile((folder_ / "missing").string(), &read), "");
}

}  // namespace
}  // namespace landmark_loop_closure
