// Robots map, stop, and come back: the node is stopped after the first lap of the corridor
// (its map committed keyframe by keyframe) and started again for the second lap with its odometry
// restarted at the origin. The second run loads the first run's keyframes as session 0 and finds
// loops into them. Also: a node killed mid-run keeps every keyframe it published (each is
// committed first); a full disk refuses keyframes to the map but not to search, and the node runs
// on; a corrupt map or a missing or corrupt model stops the node at start, saying which file.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "../core/map_damage.h"
#include "landmark_loop_closure/DatabaseFile.h"
#include "landmark_loop_closure/ResetDatabase.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "node_harness.h"

extern char** environ;

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

// Starts the node as roslaunch would, with the parameters the .test file loaded; its output goes
// to `log` when given.
pid_t startNode(const std::string& log = "") {
  std::vector<std::string> arguments = {"rosrun",
                                        "landmark_loop_closure",
                                        "loop_closure_node",
                                        "__name:=loop_closure",
                                        "image:=/camera/image_raw",
                                        "odom:=/odom"};
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  // Its own process group, so that a kill reaches the node behind rosrun too.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  if (!log.empty()) {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  }
  pid_t pid = 0;
  const int failed = posix_spawnp(&pid, "rosrun", &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  return failed == 0 ? pid : -1;
}

// Waits up to `timeout` s for the node to exit on its own; its exit status, or -1 (then killed).
int exitStatus(pid_t pid, double timeout = 30.0) {
  int status = 0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (ros::WallTime::now() > end) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      return -1;
    }
    ros::WallDuration(0.05).sleep();
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string readFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

// Publishes the corridor's first `frames` frames at the harness's rate, calling `after` on each.
void publishCorridor(test_support::NodeHarness* harness, size_t frames,
                     const std::function<void(const SequenceFrame&)>& after = {},
                     double start_stamp = 1700000000.0) {
  const CorridorWorld world;
  SequenceOptions options;
  options.start_stamp = start_stamp;
  SequenceGenerator sequence(world, CameraModel{}, options);
  ros::WallRate rate(test_support::kPublishRateHz);
  SequenceFrame frame;
  while (ros::ok() && sequence.next(&frame) && frame.index < frames) {
    harness->publish(frame.stamp, frame.odom, frame.image);
    ros::spinOnce();
    rate.sleep();
    if (after) after(frame);
  }
}

// Handles what arrives for `seconds` (messages still on their way).
void spinFor(double seconds) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
}

// SIGINT, as roslaunch stops a node; true when it exits within `timeout` seconds.
bool stopNode(pid_t pid, double timeout = 30.0) {
  kill(pid, SIGINT);
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::WallTime::now() < end) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) || WIFSIGNALED(status);
    ros::WallDuration(0.05).sleep();
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  return false;
}

// A map and every file beside it: a save never writes over any of them.
void removeMapFiles(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
}

// The true pose of the frame nearest `stamp` (stamps of loaded keyframes are stored as seconds).
const Pose2D* truthAt(const std::map<double, Pose2D>& truth, const ros::Time& stamp) {
  const auto after = truth.lower_bound(stamp.toSec() - 1e-3);
  if (after == truth.end() || std::abs(after->first - stamp.toSec()) > 1e-3) return nullptr;
  return &after->second;
}

}  // namespace

TEST(LoopClosureNode, LoopsAreFoundAcrossARestartFromTheSavedDatabase) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "lcd_node_restart.lcdb").string();
  std::filesystem::remove(path);
  ros::param::set("/loop_closure/database_path", path);

  test_support::NodeHarness harness;
  const CorridorWorld world;
  SequenceOptions options;
  options.laps = 2.0;
  options.start_stamp = 1700000000.0;
  SequenceGenerator sequence(world, CameraModel{}, options);
  std::map<double, Pose2D> truth;
  ros::WallRate rate(test_support::kPublishRateHz);

  // First run: the first lap.
  const pid_t first = startNode();
  ASSERT_GT(first, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the first run did not subscribe";
  SequenceFrame frame;
  while (ros::ok() && sequence.next(&frame) && frame.lap == 0) {
    truth[frame.stamp] = frame.truth;
    harness.publish(frame.stamp, frame.odom, frame.image);
    ros::spinOnce();
    rate.sleep();
  }
  harness.waitUntilQuiet();
  ASSERT_TRUE(stopNode(first));
  ASSERT_TRUE(std::filesystem::exists(path)) << "nothing saved at shutdown";
  const size_t first_run_keyframes = harness.keyframes().size();
  EXPECT_GT(first_run_keyframes, 150u);
  const size_t first_run_loops = harness.loops().size();  // The lap's end meets its start.
  uint64_t last_first_run_id = harness.keyframes().rbegin()->first;
  ASSERT_TRUE(harness.waitForNodeGone());

  // Second run: odometry restarted at the origin, where the robot is now.
  const pid_t second = startNode();
  ASSERT_GT(second, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the second run did not subscribe";
  const Eigen::Isometry3d restart =
      planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw).toIsometry();
  do {
    truth[frame.stamp] = frame.truth;
    const Eigen::Isometry3d odom =
        restart.inverse() * planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw).toIsometry();
    const Pose2D restarted{odom.translation().x(), odom.translation().y(),
                           std::atan2(odom.linear()(1, 0), odom.linear()(0, 0))};
    harness.publish(frame.stamp, restarted, frame.image);
    ros::spinOnce();
    rate.sleep();
  } while (ros::ok() && sequence.next(&frame));
  harness.waitUntilQuiet();

  // The services: save a copy, forget everything, load the copy back.
  const std::string copy = path + ".copy";
  removeMapFiles(copy);
  DatabaseFile save;
  save.request.path = copy;
  ASSERT_TRUE(ros::service::call("/loop_closure/save_database", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  const uint64_t stored = save.response.keyframes;
  EXPECT_EQ(stored, harness.keyframes().size());
  // Diagnostics report the map as it is: loaded keyframes included, nothing after a reset.
  const auto diagnosticBecomes = [&harness](const std::string& key, const std::string& value) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(5.0);
    while (harness.diagnostic(key) != value && ros::WallTime::now() < end) {
      ros::spinOnce();
      ros::WallDuration(0.05).sleep();
    }
    return harness.diagnostic(key) == value;
  };
  EXPECT_TRUE(diagnosticBecomes("keyframes", std::to_string(stored)))
      << harness.diagnostic("keyframes");
  ResetDatabase reset;
  ASSERT_TRUE(ros::service::call("/loop_closure/reset", reset));
  EXPECT_TRUE(reset.response.success);
  EXPECT_TRUE(diagnosticBecomes("keyframes", "0")) << harness.diagnostic("keyframes");
  // The forgotten keyframes stay on disk under another name.
  EXPECT_NE(reset.response.message.find("kept as " + path + ".reset-"), std::string::npos)
      << reset.response.message;
  DatabaseFile load;
  load.request.path = copy;
  ASSERT_TRUE(ros::service::call("/loop_closure/load_database", load));
  EXPECT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(load.response.keyframes, stored);
  EXPECT_TRUE(diagnosticBecomes("keyframes", std::to_string(stored)))
      << harness.diagnostic("keyframes");
  DatabaseFile missing;
  missing.request.path = path + ".missing";
  ASSERT_TRUE(ros::service::call("/loop_closure/load_database", missing));
  EXPECT_FALSE(missing.response.success);
  EXPECT_NE(missing.response.message.find(".missing"), std::string::npos);
  EXPECT_EQ(missing.response.keyframes, stored);  // A refused load changes nothing.
  DatabaseFile unnamed;                           // No path: which map to load is not guessed.
  ASSERT_TRUE(ros::service::call("/loop_closure/load_database", unnamed));
  EXPECT_FALSE(unnamed.response.success);
  EXPECT_NE(unnamed.response.message.find("no path given: name the map to load"), std::string::npos)
      << unnamed.response.message;
  EXPECT_EQ(unnamed.response.keyframes, stored);
  removeMapFiles(copy);
  EXPECT_TRUE(stopNode(second));

  size_t second_run_keyframes = 0;
  for (const auto& [id, session] : harness.keyframeSessions()) {
    if (id <= last_first_run_id) {
      EXPECT_EQ(session, 0u) << id;
    } else {
      EXPECT_EQ(session, 1u) << id;
      ++second_run_keyframes;
    }
  }
  EXPECT_GT(second_run_keyframes, 150u);
  size_t true_loops = 0;
  const std::vector<LoopClosure> second_run_loops(harness.loops().begin() + first_run_loops,
                                                  harness.loops().end());
  for (const LoopClosure& loop : second_run_loops) {
    SCOPED_TRACE("loop " + std::to_string(loop.query_id) + " -> " + std::to_string(loop.match_id));
    EXPECT_EQ(loop.query_session, 1u);
    EXPECT_EQ(loop.match_session, 0u);  // The second lap revisits only the first.
    EXPECT_GT(loop.query_id, last_first_run_id);
    EXPECT_LE(loop.match_id, last_first_run_id);
    const Pose2D* query = truthAt(truth, loop.query_stamp);
    const Pose2D* match = truthAt(truth, loop.match_stamp);
    ASSERT_TRUE(query && match);
    // The rule's distance alone: the two sessions' stamps are not one timeline.
    const double distance = std::hypot(query->x - match->x, query->y - match->y);
    EXPECT_LE(distance, eval::TrueLoopRule{}.max_distance_m);
    true_loops += distance <= eval::TrueLoopRule{}.max_distance_m ? 1 : 0;
  }
  std::printf("first run %zu keyframes, second run %zu keyframes, %zu loops across the restart\n",
              first_run_keyframes, second_run_keyframes, second_run_loops.size());
  EXPECT_GE(true_loops, 20u);
  std::filesystem::remove(path);
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::temp_directory_path())) {
    if (entry.path().string().rfind(path + ".reset-", 0) == 0) std::filesystem::remove(entry);
  }
}

TEST(LoopClosureNode, ACorruptDatabaseFileStopsTheNodeAndIsLeftAlone) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "lcd_node_corrupt.lcdb").string();
  // The earlier format, a file that is no map at all, and an empty file (a new map is made only
  // where no file is).
  for (const std::string& garbage :
       {std::string("LLCKFDB\nnot really a database"),
        std::string(4096, 'x') + "no SQLite header either", std::string()}) {
    {
      std::ofstream file(path, std::ios::binary);
      file << garbage;
    }
    ros::param::set("/loop_closure/database_path", path);
    const pid_t node = startNode();
    ASSERT_GT(node, 0);
    const int status = exitStatus(node);
    EXPECT_NE(status, -1) << "the node started with a corrupt map";
    EXPECT_NE(status, 0);
    EXPECT_EQ(readFile(path), garbage);  // Left as it was.
    EXPECT_FALSE(std::filesystem::exists(path + "-vectors"));
  }
  std::filesystem::remove(path);
  ros::param::set("/loop_closure/database_path", std::string());
}

TEST(LoopClosureNode, AMapWithADamagedPageIsReportedAndNeverWrittenTo) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "lcd_node_damaged_page.db").string();
  removeMapFiles(path);
  ros::param::set("/loop_closure/database_path", path);
  test_support::NodeHarness harness;
  const pid_t first = startNode();
  ASSERT_GT(first, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the first run did not subscribe";
  publishCorridor(&harness, 150);
  harness.waitUntilQuiet();
  ASSERT_TRUE(stopNode(first));
  ASSERT_TRUE(harness.waitForNodeGone());
  ASSERT_TRUE(test_support::turnOverMiddlePage(path));  // As a failing disk would.
  const std::string damaged_map = readFile(path);
  const std::string damaged_rows = readFile(path + "-vectors");
  const size_t keyframes_before = harness.keyframes().size();
  const std::string log =
      (std::filesystem::temp_directory_path() / "lcd_node_damaged_page.log").string();
  const pid_t second = startNode(log);
  ASSERT_GT(second, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the second run did not subscribe";
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
  while (harness.diagnostic("map check") != "damaged" && ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  EXPECT_EQ(harness.diagnostic("map check"), "damaged") << "said without a keyframe";
  // Frames go on: keyframes are made and published, none is written to the damaged map.
  publishCorridor(&harness, 60, {}, 1700001000.0);
  harness.waitUntilQuiet();
  EXPECT_GT(harness.keyframes().size(), keyframes_before);
  EXPECT_TRUE(stopNode(second));
  EXPECT_TRUE(readFile(path) == damaged_map) << "the damaged map was written to";
  EXPECT_TRUE(readFile(path + "-vectors") == damaged_rows) << "its rows were written to";
  // The last line counts what is on disk, and says which keyframes are not there.
  const std::string output = readFile(log);
  std::smatch found;
  ASSERT_TRUE(std::regex_search(
      output, found,
      std::regex("Map [^ ]+: ([0-9]+) keyframes in the file; ([0-9]+) keyframes of this run are "
                 "not in it \\(the map is damaged")))
      << output;
  EXPECT_EQ(std::stoul(found[1]), keyframes_before);
  EXPECT_EQ(std::stoul(found[2]), harness.keyframes().size() - keyframes_before);
  EXPECT_EQ(output.find("each committed"), std::string::npos) << output;
  std::filesystem::remove(log);
  ros::param::set("/loop_closure/database_path", std::string());
  removeMapFiles(path);
}

TEST(LoopClosureNode, AMissingOrCorruptModelFileStopsTheNodeNamingIt) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path();
  const std::string missing = (folder / "lcd_no_such_model.onnx").string();
  const std::string corrupt = (folder / "lcd_corrupt_model.onnx").string();
  std::filesystem::remove(missing);
  {
    std::ofstream file(corrupt, std::ios::binary);
    file << "not an ONNX protobuf";
  }
  // Described (as a network of one's own must be), so that the file itself is what is refused.
  std::filesystem::copy_file(
      std::filesystem::path(PACKAGE_SOURCE_DIR) / "model" / "mobilenet_v2.onnx.json",
      corrupt + ".json", std::filesystem::copy_options::overwrite_existing);
  ros::param::set("/loop_closure/database_path", std::string());
  const std::string log = (folder / "lcd_model_node.log").string();
  for (const std::string& model : {missing, corrupt}) {
    SCOPED_TRACE(model);
    ros::param::set("/loop_closure/advanced/descriptor/backbone/model", model);
    const pid_t node = startNode(log);
    ASSERT_GT(node, 0);
    const int status = exitStatus(node);
    EXPECT_NE(status, -1) << "the node started without a usable model";
    EXPECT_NE(status, 0);
    const std::string output = readFile(log);
    EXPECT_NE(output.find(model), std::string::npos) << output;
    size_t fatal_lines = 0;
    for (size_t at = output.find("[FATAL]"); at != std::string::npos;
         at = output.find("[FATAL]", at + 1)) {
      ++fatal_lines;
    }
    EXPECT_EQ(fatal_lines, 1u) << "one FATAL line per refusal:\n" << output;
  }
  // A parameter out of its range: one FATAL naming it.
  ros::param::set("/loop_closure/advanced/descriptor/backbone/model", std::string());
  ros::param::set("/loop_closure/advanced/worker_queue_size", 2000000000);
  const pid_t node = startNode(log);
  ASSERT_GT(node, 0);
  EXPECT_NE(exitStatus(node), 0);
  const std::string output = readFile(log);
  EXPECT_NE(output.find("worker_queue_size must be in [1, 10000] (got 2000000000)"),
            std::string::npos)
      << output;
  EXPECT_EQ(output.find("[FATAL]"), output.rfind("[FATAL]")) << output;
  ros::param::set("/loop_closure/advanced/worker_queue_size", 8);
  std::filesystem::remove(corrupt);
  std::filesystem::remove(corrupt + ".json");
  std::filesystem::remove(log);
}

TEST(LoopClosureNode, AModelFileTheDescriptorDoesNotReadIsWarnedAboutOnce) {
  // advanced/descriptor/model is the package encoder's file; the default backbone reads its own
  // (advanced/descriptor/backbone/model), so a garbage file there changes nothing and must be said.
  const std::filesystem::path folder = std::filesystem::temp_directory_path();
  const std::string garbage = (folder / "lcd_ignored_model.onnx").string();
  {
    std::ofstream file(garbage, std::ios::binary);
    file << "not an ONNX protobuf";
  }
  const std::string log = (folder / "lcd_ignored_model_node.log").string();
  ros::param::set("/loop_closure/database_path", std::string());
  ros::param::set("/loop_closure/advanced/descriptor/model", garbage);
  test_support::NodeHarness harness;
  const pid_t node = startNode(log);
  ASSERT_GT(node, 0);
  EXPECT_TRUE(harness.waitForNode()) << readFile(log);
  EXPECT_TRUE(stopNode(node));
  const std::string output = readFile(log);
  const std::string warning =
      "advanced/descriptor/type backbone does not read advanced/descriptor/model: it is set";
  EXPECT_NE(output.find(warning), std::string::npos) << output;
  EXPECT_EQ(output.find(warning), output.rfind(warning)) << "once:\n" << output;
  ros::param::del("/loop_closure/advanced/descriptor/model");
  std::filesystem::remove(garbage);
  std::filesystem::remove(log);
}

TEST(LoopClosureNode, AKilledNodeKeepsEveryKeyframeItCommitted) {
  const std::string path = (std::filesystem::temp_directory_path() / "lcd_node_killed.db").string();
  std::filesystem::remove(path);
  ros::param::set("/loop_closure/database_path", path);

  test_support::NodeHarness harness;
  const pid_t first = startNode();
  ASSERT_GT(first, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the first run did not subscribe";
  // Killed mid-run, frames still arriving and keyframes in the worker's hands.
  publishCorridor(&harness, 300);
  kill(-first, SIGKILL);
  waitpid(first, nullptr, 0);
  // A keyframe is published after it is committed: every one received must be in the map.
  spinFor(1.0);
  const std::map<uint64_t, ros::Time> published = harness.keyframes();
  ASSERT_GT(published.size(), 50u);

  // The master still lists the killed node until the new one takes its name: call until the new
  // one answers.
  const pid_t second = startNode();
  ASSERT_GT(second, 0);
  DatabaseFile save;
  save.request.path = path + ".copy";
  removeMapFiles(save.request.path);
  bool answered = false;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(60.0);
  while (!answered && ros::WallTime::now() < end) {
    answered = ros::service::call("/loop_closure/save_database", save);
    if (!answered) ros::WallDuration(0.2).sleep();
  }
  ASSERT_TRUE(answered) << "the restarted node did not answer";
  EXPECT_TRUE(save.response.success) << save.response.message;
  EXPECT_GE(save.response.keyframes, published.size());
  EXPECT_TRUE(stopNode(second));

  const auto copy = KeyframeStore::openExisting(save.request.path);
  for (const auto& [id, stamp] : published) {
    const std::optional<KeyframeRecord> keyframe = copy->get(id);
    ASSERT_TRUE(keyframe) << "published keyframe " << id << " was not in the map after the kill";
    EXPECT_NEAR(keyframe->stamp, stamp.toSec(), 1e-6);
  }
  std::printf("killed after %zu published keyframes; the map held %lu\n", published.size(),
              save.response.keyframes);
  ros::param::set("/loop_closure/database_path", std::string());
  std::filesystem::remove(path);
  removeMapFiles(save.request.path);
}

TEST(LoopClosureNode, AStopUnderLoadAccountsForEveryStoredKeyframe) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path();
  const std::string path = (folder / "lcd_node_stopped.db").string();
  const std::string log = (folder / "lcd_node_stopped.log").string();
  removeMapFiles(path);
  ros::param::set("/loop_closure/database_path", path);
  test_support::NodeHarness harness;
  const pid_t node = startNode(log);
  ASSERT_GT(node, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  // SIGINT, as roslaunch stops a node, while frames still arrive and keyframes are queued.
  publishCorridor(&harness, 300, [node](const SequenceFrame& frame) {
    if (frame.index == 250) kill(node, SIGINT);
  });
  EXPECT_NE(exitStatus(node), -1) << "the node did not stop";
  spinFor(1.0);
  const std::string output = readFile(log);
  // "Map PATH: N keyframes, each committed when it was stored[; K of them stored while ROS shut
  // down, which may not have reached keyframes' subscribers]..."
  std::smatch found;
  ASSERT_TRUE(std::regex_search(output, found, std::regex("Map [^ ]+: ([0-9]+) keyframes, each")))
      << output;
  const size_t stored = std::stoul(found[1]);
  size_t unpublished = 0;
  if (std::regex_search(
          output, found,
          std::regex("; ([0-9]+) of them stored while ROS shut down, which may not have"))) {
    unpublished = std::stoul(found[1]);
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), stored);
  // Every keyframe received is in the map, and every one in the map was received or is among
  // those the last line says may not have been.
  EXPECT_LE(harness.keyframes().size(), stored) << output;
  EXPECT_GE(harness.keyframes().size() + unpublished, stored)
      << "a keyframe in the map was neither received nor said possibly unreceived:\n"
      << output;
  std::printf("stopped with %zu keyframes in the map, %zu published, %zu said unpublished\n",
              stored, harness.keyframes().size(), unpublished);
  ros::param::set("/loop_closure/database_path", std::string());
  removeMapFiles(path);
  std::filesystem::remove(log);
}

TEST(LoopClosureNode, AFullDiskKeepsTheNodeRunningAndPublishesOnlyWhatTheMapHolds) {
  const std::string path = (std::filesystem::temp_directory_path() / "lcd_node_full.db").string();
  const std::string log = (std::filesystem::temp_directory_path() / "lcd_node_full.log").string();
  for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
  ros::param::set("/loop_closure/database_path", path);

  // The disk fills after ~1 MB of map: a file-size limit the node inherits, with SIGXFSZ ignored
  // so that writes past it fail as they do on a full disk (ENOSPC) instead of killing the node.
  rlimit previous{};
  getrlimit(RLIMIT_FSIZE, &previous);
  rlimit limited = previous;
  limited.rlim_cur = 1 << 20;
  signal(SIGXFSZ, SIG_IGN);
  setrlimit(RLIMIT_FSIZE, &limited);
  test_support::NodeHarness harness;
  const pid_t node = startNode(log);
  setrlimit(RLIMIT_FSIZE, &previous);
  ASSERT_GT(node, 0);
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  size_t published_before_full = 0;
  publishCorridor(&harness, 400, [&](const SequenceFrame& frame) {
    if (frame.index == 50) published_before_full = harness.keyframes().size();
  });
  spinFor(2.0);
  EXPECT_EQ(waitpid(node, nullptr, WNOHANG), 0) << "the node died when the disk filled";
  const size_t published = harness.keyframes().size();
  EXPECT_TRUE(stopNode(node)) << "the node did not stop on SIGINT";
  const std::string output = readFile(log);
  EXPECT_NE(output.find("is neither stored nor published"), std::string::npos)
      << "the disk never filled, or the node did not say so:\n"
      << output;
  EXPECT_TRUE(harness.summarySaid("keyframes not stored")) << "diagnostics did not go to ERROR";
  const std::string refused = harness.diagnostic("keyframes not stored (map file refused them)");
  EXPECT_GT(refused.empty() ? 0 : std::stoul(refused), 20u) << "the node stopped trying";

  // Keyframe.msg's promise: every keyframe published is in the map (issue 80); the map holds
  // those committed before the disk filled, whole.
  const auto map = KeyframeStore::openExisting(path);
  std::printf("disk full: %zu keyframes published, %zu in the map, %s refused\n", published,
              map->size(), refused.c_str());
  EXPECT_GT(published_before_full, 5u);
  EXPECT_GT(map->size(), 5u);
  EXPECT_LE(published, map->size());
  for (const Keyframe& keyframe : harness.publishedKeyframes()) {
    EXPECT_TRUE(map->get(keyframe.id).has_value())
        << "keyframe " << keyframe.id << " was published and the map lacks it";
  }
  map->forEach([](const KeyframeRecord&) {});  // Every committed keyframe reads back whole.
  ros::param::set("/loop_closure/database_path", std::string());
  for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
  std::filesystem::remove(log);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_restart");
  return RUN_ALL_TESTS();
}
