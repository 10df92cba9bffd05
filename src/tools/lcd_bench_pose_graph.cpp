// lcd_bench_pose_graph: the pose-graph backend's optimisation time per loop as the graph grows.
// A robot drives laps of a rectangle (sim::driveLaps, a keyframe every 0.5 m, odometry with a
// turn bias); from the second lap on, every keyframe within 0.3 m of one a lap earlier closes a
// loop. Loops are given as they come; the last --timed loops are each optimised on arrival and
// timed (median, p99); before them the graph is optimised every --every loops, as a backend that
// keeps up would have left it. One thread, one run.
//   lcd_bench_pose_graph [--keyframes N] [--timed K] [--every E]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/sim/driven_laps.h"

using namespace landmark_loop_closure;

int main(int argc, char** argv) {
  size_t keyframes = 473;
  size_t timed = 100;
  size_t every = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const size_t value = std::strtoul(argv[i + 1], nullptr, 10);
    if (key == "--keyframes") {
      keyframes = value;
    } else if (key == "--timed") {
      timed = value;
    } else if (key == "--every") {
      every = value;
    } else {
      std::fprintf(stderr, "usage: lcd_bench_pose_graph [--keyframes N] [--timed K] [--every E]\n");
      return 2;
    }
  }
  sim::DrivenLapsOptions drive_options;
  drive_options.laps = 1;
  const size_t per_lap = sim::driveLaps(drive_options).keyframes_per_lap;
  drive_options.laps = static_cast<int>((keyframes + per_lap - 1) / per_lap);
  const sim::DrivenLaps drive = sim::driveLaps(drive_options);

  // Every loop the drive closes, in the order they come.
  std::vector<LoopConstraint> loops;
  for (size_t i = per_lap; i < keyframes; ++i) {
    const size_t match = i - per_lap;
    if ((drive.truth[i].position - drive.truth[match].position).norm() > 0.3) continue;
    LoopConstraint loop;
    loop.query_id = i;
    loop.match_id = match;
    loop.query_T_match = drive.truth[i].toIsometry().inverse() * drive.truth[match].toIsometry();
    loop.covariance.setZero();
    loop.covariance.diagonal() << 9e-4, 9e-4, 9e-4, 1e-4, 1e-4, 1e-4;
    loops.push_back(loop);
  }
  const size_t first_timed = loops.size() > timed ? loops.size() - timed : 0;

  PoseGraph graph;
  std::vector<double> times;
  size_t next_loop = 0;
  size_t since_optimised = 0;
  for (size_t i = 0; i < keyframes; ++i) {
    graph.addKeyframe(i, drive.odometry[i]);
    while (next_loop < loops.size() && loops[next_loop].query_id == i) {
      graph.addLoop(loops[next_loop]);
      const bool timed_loop = next_loop >= first_timed;
      ++next_loop;
      if (timed_loop) {
        const OptimisationReport report = graph.optimise();
        times.push_back(report.milliseconds);
      } else if (++since_optimised >= every) {
        graph.optimise();
        since_optimised = 0;
      }
    }
  }
  double squared = 0.0;
  double odometry_squared = 0.0;
  for (size_t i = 0; i < keyframes; ++i) {
    squared += (graph.optimisedPose(i)->position - drive.truth[i].position).squaredNorm();
    odometry_squared += (drive.odometry[i].position - drive.truth[i].position).squaredNorm();
  }
  const eval::Percentiles time = eval::percentiles(times);
  size_t refused = 0;
  for (const LoopVerdict& verdict : graph.loopVerdicts()) {
    refused += verdict.decision != LoopDecision::kAccepted ? 1 : 0;
  }
  std::printf(
      "keyframes %zu (%d laps), loops %zu (%zu refused), timed %zu: optimisation per loop "
      "median %.2f ms, p99 %.2f ms; RMSE odometry %.3f m, corrected %.3f m\n",
      keyframes, drive_options.laps, loops.size(), refused, times.size(), time.median, time.p99,
      std::sqrt(odometry_squared / keyframes), std::sqrt(squared / keyframes));
  return 0;
}
