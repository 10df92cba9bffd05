// lcd_bench_fleet: one fleet node's search as robots share keyframes (issue 68). --robots streams
// of synthetic global vectors (spread like the shipped descriptor's of real images, 4 320 values
// as the default backbone's), each robot driving the same route from its own start, 10 keyframes
// a second each, interleaved: every keyframe's row is kept (FleetMatcher::addRow) and searched in
// the other robots' rows (FleetMatcher::query: score, chain, place ratio, calibrated tail), on
// one thread. At each checkpoint it prints the time per keyframe (median, p99), the keyframes a
// second one core sustains at that size, the matcher's bytes and the process's resident set.
//   lcd_bench_fleet [--robots 4] [--keyframes 5000] [--checkpoints 500,1000,2500,5000]
//                   [--dimension 4320]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench_workload.h"
#include "command_line.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"

namespace {

using namespace landmark_loop_closure;
using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(p * values.size()));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

double residentMegabytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  size_t robots = 4, keyframes = 5000;
  int dimension = 4320;
  std::vector<size_t> checkpoints = {500, 1000, 2500, 5000};
  CLI::App app{
      "Several robots' keyframes into one fleet matcher: search time, memory, candidates."};
  app.add_option("--robots", robots, "robots sharing keyframes")
      ->capture_default_str()
      ->check(CLI::Range(size_t{2}, size_t{1000}));
  app.add_option("--keyframes", keyframes, "keyframes a robot")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--checkpoints", checkpoints, "rows a robot at which a line is printed")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--dimension", dimension, "values a row")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  // The route's places, then each robot's view of them: the place's vector plus its own noise.
  bench::Route route(dimension, 11, bench::RouteShape::kMeasured);
  std::vector<std::vector<float>> places(keyframes);
  for (std::vector<float>& place : places) place = route.next();

  const std::string identity = "bench descriptor";
  FleetMatcher matcher(FleetOptions{}, identity, dimension);
  std::printf(
      "lcd_bench_fleet: %zu robots, one fleet node, %d values a row (%zu bytes), 10 keyframes a "
      "second each (%zu a second in all), one thread\n",
      robots, dimension, sizeof(float) + static_cast<size_t>(dimension), 10 * robots);
  std::printf(
      "rows/robot  rows   search ms median  p99    keyframes/s sustained  matcher MB  RSS MB"
      "  candidates (at the query's place, within 3)\n");
  std::vector<double> window_ms;
  size_t candidates = 0, true_candidates = 0;
  size_t next_checkpoint = 0;
  for (size_t k = 0; k < keyframes; ++k) {
    for (size_t robot = 0; robot < robots; ++robot) {
      // Each robot sees the place with noise of its own (cosine ~0.9 to it).
      const std::vector<float> view =
          route.revisit(places[(k + robot * keyframes / robots) % keyframes]);
      SharedKeyframe row;
      row.robot = "robot_" + std::to_string(robot);
      row.map_id = robot + 1;
      row.id = k;
      row.stamp_ns = static_cast<int64_t>(k) * 100000000;
      row.pose.position.x() = static_cast<double>(k);
      row.odometry_frame = row.robot + "/odom";
      row.descriptor_fingerprint = descriptorFingerprint(identity);
      row.global_row = QuantizedVectors::encode(view);
      const Clock::time_point start = Clock::now();
      if (const std::optional<FleetCandidate> candidate = matcher.query(row)) {
        ++candidates;
        // The route's place of the match (its robot's start, its id) against the query's.
        const size_t other = static_cast<size_t>(candidate->match.map_id - 1);
        const size_t match_place = (candidate->match.id + other * keyframes / robots) % keyframes;
        const size_t query_place = (k + robot * keyframes / robots) % keyframes;
        const size_t gap =
            match_place > query_place ? match_place - query_place : query_place - match_place;
        true_candidates += std::min(gap, keyframes - gap) <= 3 ? 1 : 0;
      }
      matcher.addRow(row, 0.1 * static_cast<double>(k), 0);
      window_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    if (next_checkpoint < checkpoints.size() && k + 1 == checkpoints[next_checkpoint]) {
      const double median = percentile(window_ms, 0.5);
      std::printf("%10zu %6zu  %16.2f %6.2f  %21.0f  %10.1f %7.1f  %zu (%zu)\n", k + 1,
                  matcher.rows(), median, percentile(window_ms, 0.99),
                  median > 0.0 ? 1000.0 / median : 0.0, matcher.bytes() / 1e6, residentMegabytes(),
                  candidates, true_candidates);
      window_ms.clear();
      ++next_checkpoint;
    }
  }
  return 0;
}
