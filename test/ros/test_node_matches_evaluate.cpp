// `lcd_evaluate --detector --bag` reproduces the running node: a generated demo bag is played
// into the node, then evaluated offline with the same configuration, and both must give the same
// loops (same keyframe ids, same scores, same verdicts of the geometric check).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include "node_harness.h"

using namespace landmark_loop_closure;

namespace {

struct OfflineLoop {
  double score = 0.0;
  bool verified = false;
};

using LoopKey = std::pair<uint64_t, uint64_t>;  // query id, match id

// loops_<descriptor>.csv of lcd_evaluate: query_id,match_id,query_frame,match_frame,score,...
std::map<LoopKey, OfflineLoop> readOfflineLoops(const std::string& folder) {
  std::map<LoopKey, OfflineLoop> loops;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("loops_", 0) != 0) continue;
    std::ifstream file(entry.path());
    std::string line;
    std::getline(file, line);  // header
    while (std::getline(file, line)) {
      std::stringstream fields(line);
      std::string query, match, query_frame, match_frame, score, verified;
      std::getline(fields, query, ',');
      std::getline(fields, match, ',');
      std::getline(fields, query_frame, ',');
      std::getline(fields, match_frame, ',');
      std::getline(fields, score, ',');
      std::getline(fields, verified, ',');
      loops[{std::stoull(query), std::stoull(match)}] = {std::stod(score), verified == "1"};
    }
  }
  return loops;
}

// Plays the bag's images, odometry and camera_info in recorded order at `rate_hz` frames per
// second; returns the number of images.
size_t playBag(const std::string& path, double rate_hz) {
  ros::NodeHandle node;
  ros::Publisher images = node.advertise<sensor_msgs::Image>("/camera/image_raw", 100);
  ros::Publisher odometry = node.advertise<nav_msgs::Odometry>("/odom", 100);
  ros::Publisher infos = node.advertise<sensor_msgs::CameraInfo>("/camera/camera_info", 100);
  ros::WallDuration(1.0).sleep();  // let the node connect to these publishers
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery({"/camera/image_raw", "/odom", "/camera/camera_info"}));
  ros::WallRate rate(rate_hz);
  size_t frames = 0;
  for (const rosbag::MessageInstance& message : view) {
    if (auto image = message.instantiate<sensor_msgs::Image>()) {
      images.publish(image);
      ++frames;
      ros::spinOnce();
      rate.sleep();
    } else if (auto odom = message.instantiate<nav_msgs::Odometry>()) {
      odometry.publish(odom);
    } else if (auto info = message.instantiate<sensor_msgs::CameraInfo>()) {
      infos.publish(info);
    }
  }
  return frames;
}

}  // namespace

TEST(LoopClosureNode, PublishesTheLoopsLcdEvaluateReportsForTheSameBag) {
  char folder_template[] = "/tmp/lcd_node_matches_evaluate_XXXXXX";
  ASSERT_NE(mkdtemp(folder_template), nullptr);
  const std::string folder = folder_template;
  const std::string bag = folder + "/corridor.bag";
  // Two laps at 4 frames per second: every place revisited, a few hundred keyframes.
  ASSERT_EQ(0, std::system((std::string(MAKE_DEMO_BAG) + " " + bag + " 2 4 > /dev/null").c_str()));

  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const size_t frames = playBag(bag, 20.0);
  harness.waitUntilQuiet(10.0, 300.0);
  ASSERT_GT(frames, 500u);
  ASSERT_EQ(harness.diagnostic("keyframes dropped (worker busy)"), "0")
      << "the node dropped keyframes, so it did not see what lcd_evaluate sees";

  const std::string results = folder + "/evaluate";
  const std::string command = std::string(LCD_EVALUATE) + " --detector --bag " + bag +
                              " --config " + DEMO_CONFIG +
                              " --truth-topic /ground_truth --gt-distance 2.5 --gt-gap 20"
                              " --sweep-steps 2 --output " +
                              results + " > " + folder + "/evaluate.log 2>&1";
  ASSERT_EQ(0, std::system(command.c_str())) << "see " << folder << "/evaluate.log";
  const std::map<LoopKey, OfflineLoop> offline = readOfflineLoops(results);

  std::map<LoopKey, LoopClosure> online;
  for (const LoopClosure& loop : harness.loops()) online[{loop.query_id, loop.match_id}] = loop;
  std::printf("node: %zu keyframes, %zu loops; lcd_evaluate: %zu loops\n",
              harness.keyframes().size(), online.size(), offline.size());
  EXPECT_GT(online.size(), 50u) << "the demo's two laps give many loops";
  EXPECT_EQ(online.size(), harness.loops().size()) << "a loop was published twice";
  EXPECT_EQ(online.size(), offline.size());
  for (const auto& [key, loop] : online) {
    const auto found = offline.find(key);
    if (found == offline.end()) {
      ADD_FAILURE() << "the node published keyframe " << key.first << " -> " << key.second
                    << " (score " << loop.score << "), lcd_evaluate did not";
      continue;
    }
    EXPECT_NEAR(loop.score, found->second.score, 1e-4 * std::max(1.0, std::abs(loop.score)))
        << "loop " << key.first << " -> " << key.second;
    EXPECT_EQ(static_cast<bool>(loop.verified), found->second.verified)
        << "loop " << key.first << " -> " << key.second;
  }
  for (const auto& [key, loop] : offline) {
    if (online.count(key) == 0) {
      ADD_FAILURE() << "lcd_evaluate reported keyframe " << key.first << " -> " << key.second
                    << " (score " << loop.score << "), the node did not publish it";
    }
  }
  if (!HasFailure()) std::filesystem::remove_all(folder);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_matches_evaluate");
  return RUN_ALL_TESTS();
}
