// lcd_bench_markers: what the node's rviz markers cost per keyframe as the map grows. For each
// map size the markers of N keyframes (a loop every fourth) are built, then 4000 more keyframes
// are added one at a time, each followed by what the node does: take the change set and
// serialise it as ROS would for a subscriber. Beside it, the earlier way: every marker of the map
// (snapshot) serialised at every keyframe.
//   lcd_bench_markers [--sizes 1000,10000,100000]
// Prints a markdown table: per keyframe, median and p99 (ms), and the bytes sent.
#include <ros/serialization.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "../ros/loop_markers.h"
#include "command_line.h"
#include "landmark_loop_closure/eval/metrics.h"

using namespace landmark_loop_closure;

namespace {

constexpr int kTimedKeyframes = 4000;  // Four chunks: every fill level of a chunk.

Pose poseAt(size_t index) {
  Pose pose;
  const double angle = 0.01 * static_cast<double>(index);
  pose.position = Eigen::Vector3d(10.0 * std::cos(angle), 10.0 * std::sin(angle), 0.0);
  return pose;
}

void add(LoopMarkers* markers, size_t index) {
  markers->addKeyframe(poseAt(index));
  if (index % 4 != 0 || index < 100) return;
  AcceptedLoop loop;
  loop.score = 0.5;
  loop.query_pose = poseAt(index);
  loop.match_pose = poseAt(index - 100);
  VerificationResult check;
  check.verdict = VerificationVerdict::kAccepted;
  loop.verification = check;
  markers->addLoop(loop);
}

size_t serialise(const visualization_msgs::MarkerArray& array, std::vector<uint8_t>* buffer) {
  const uint32_t length = ros::serialization::serializationLength(array);
  buffer->resize(length);
  ros::serialization::OStream stream(buffer->data(), length);
  ros::serialization::serialize(stream, array);
  return length;
}

double mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (const double value : values) sum += value;
  return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
}

struct Row {
  std::vector<double> ms;
  double bytes = 0.0;
};

Row measure(size_t size, bool incremental) {
  LoopMarkers markers("odom", 0.3, false);
  for (size_t i = 0; i < size; ++i) {
    add(&markers, i);
    if (i % 1000 == 0) markers.changes(ros::Time(1.0));
  }
  markers.changes(ros::Time(1.0));
  Row row;
  std::vector<uint8_t> buffer;
  for (int k = 0; k < kTimedKeyframes; ++k) {
    const auto start = std::chrono::steady_clock::now();
    add(&markers, size + static_cast<size_t>(k));
    const visualization_msgs::MarkerArray array =
        incremental ? markers.changes(ros::Time(2.0)) : markers.snapshot(ros::Time(2.0));
    row.bytes += static_cast<double>(serialise(array, &buffer));
    row.ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
  }
  row.bytes /= kTimedKeyframes;
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<size_t> sizes = {1000, 10000, 100000};
  CLI::App app{"rviz markers of a map: time and bytes to publish changes only or every marker."};
  app.add_option("--sizes", sizes, "map sizes in keyframes")->delimiter(',')->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  std::printf(
      "| keyframes | changes only: median / p99 / mean ms | bytes | every marker: median / p99 / "
      "mean ms | bytes |\n|---|---|---|---|---|\n");
  for (const size_t size : sizes) {
    const Row changes = measure(size, true);
    const Row everything = measure(size, false);
    const eval::Percentiles changes_ms = eval::percentiles(changes.ms);
    const eval::Percentiles everything_ms = eval::percentiles(everything.ms);
    std::printf("| %zu | %.4f / %.4f / %.4f | %.0f | %.3f / %.3f / %.3f | %.0f |\n", size,
                changes_ms.median, changes_ms.p99, mean(changes.ms), changes.bytes,
                everything_ms.median, everything_ms.p99, mean(everything.ms), everything.bytes);
    std::fflush(stdout);
  }
  return 0;
}
