// Stamps that jump back and odometry that never pairs with the images. With time_jump_back: reset
// the node forgets its keyframes when a bag restarts and maps the replay afresh; with odometry
// stamped on another clock, nothing is processed and the diagnostics say why; when input
// stops, they name the silent topics.
#include <filesystem>

#include "landmark_loop_closure/DatabaseFile.h"
#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

uint64_t storedKeyframes() {
  DatabaseFile save;
  save.request.path = (std::filesystem::temp_directory_path() / "lcd_time_jump.lcdb").string();
  // A save never writes over a file: the copy and its rows go before and after.
  const auto remove_copy = [&save] {
    for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors", "-summaries"}) {
      std::filesystem::remove(save.request.path + suffix);
    }
  };
  remove_copy();
  const bool saved = ros::service::call("/loop_closure/save_database", save);
  remove_copy();
  if (!saved || !save.response.success) return 0;
  return save.response.keyframes;
}

}  // namespace

TEST(LoopClosureNode, ABagRestartResetsTheDatabaseAndTheReplayIsMapped) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  harness.publishCorridor(0, 300);
  harness.waitUntilQuiet();
  const size_t first_play = harness.keyframes().size();
  ASSERT_GT(first_play, 40u);
  EXPECT_EQ(storedKeyframes(), first_play);

  // The same frames again, same stamps: time went back ~10 s.
  harness.publishCorridor(0, 300);
  harness.waitUntilQuiet();
  const size_t replay = harness.keyframes().size() - first_play;
  EXPECT_GT(replay, first_play * 9 / 10) << "the replay was dropped instead of mapped";
  EXPECT_EQ(storedKeyframes(), replay) << "the first play's keyframes were not forgotten";
  EXPECT_TRUE(harness.loops().empty());
}

TEST(LoopClosureNode, OdometryThatNeverPairsIsReportedAndNothingIsProcessed) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const size_t before = harness.keyframes().size();
  // 4 s of frames (input_timeout is 2 s in the .test file), odometry on another clock, 1000 s
  // ahead (a small offset would only pair each image with older odometry).
  const size_t published = harness.publishCorridor(300, 540, 1000.0);
  ASSERT_GT(published, 200u);
  harness.waitUntilQuiet(1.5);
  EXPECT_EQ(harness.keyframes().size(), before);
  EXPECT_TRUE(harness.summarySaid("none paired for"));
  // Then silence: the diagnostics name the topics that stopped.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(3.5);
  while (ros::ok() && ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  EXPECT_TRUE(harness.summarySaid("No input for 2 s on /camera/image_raw and /odom"));
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_time_jump");
  return RUN_ALL_TESTS();
}
