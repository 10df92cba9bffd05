// tf mode with transforms that never cover the images' stamps (the odometry runs on another
// clock): every image is dropped after tf_timeout, counted, and the diagnostics name the missing
// transform; then transforms that do cover the stamps make keyframes again.
#include <string>

#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

constexpr double kStartStamp = 5000.0;  // Room for tf stamped 1000 s before the images.

TEST(LoopClosureNode, ImagesWithoutTransformAreDroppedAndReported) {
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  // 4 s of frames (input_timeout is 2 s), tf 1000 s behind: no transform reaches any image's
  // stamp (tf 1000 s ahead would make tf2 discard the later, correct transforms as too old).
  ASSERT_GT(harness.publishCorridor(0, 240, -1000.0, kStartStamp), 200u);
  harness.waitUntilQuiet(1.5);
  EXPECT_TRUE(harness.keyframes().empty());
  const std::string timeouts = harness.diagnostic("tf timeouts");
  ASSERT_FALSE(timeouts.empty()) << "no tf timeout counter in the diagnostics";
  EXPECT_GT(std::stoul(timeouts), 100u);
  EXPECT_TRUE(harness.summarySaid("No input for 2 s on tf odom -> base_link"));

  // Transforms at the images' stamps: processing resumes.
  harness.publishCorridor(240, 420, 0.0, kStartStamp);
  harness.waitUntilQuiet(1.5);
  EXPECT_FALSE(harness.keyframes().empty());
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_tf_timeout");
  return RUN_ALL_TESTS();
}
