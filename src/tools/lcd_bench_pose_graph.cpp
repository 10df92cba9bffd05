// lcd_bench_pose_graph: the pose-graph backend's optimisation time per loop as the graph grows.
// A robot drives laps of a rectangle (sim::driveLaps, a keyframe every 0.5 m, odometry with a
// turn bias); from the second lap on, every keyframe within 0.3 m of one a lap earlier closes a
// loop. Loops are given as they come; the last --timed loops are each optimised on arrival and
// timed (median, p99); before them the graph is optimised every --every loops, as a backend that
// keeps up would have left it. One thread, one run.
//   lcd_bench_pose_graph [--keyframes N] [--timed K] [--every E]
// With --kitti POSES (KITTI odometry's ground truth, e.g. ../shared/data/kitti_poses/00.txt) the
// route is a real one instead (tools/kitti_route.h): keyframes every 2 m, the demo's odometry
// drift, every revisit a loop, --wrong-loops F of them wrong (default 0.05); every loop is
// optimised on arrival. --max-loop-error-sd and --loop-loss-scale override the defaults, to
// choose them on one sequence and check them on another.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "command_line.h"
#include "kitti_route.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/eval/ground_truth.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/sim/driven_laps.h"

using namespace landmark_loop_closure;

namespace {

int runKitti(const std::string& poses_path, const tools::KittiRouteOptions& route_options,
             const PoseGraphOptions& options) {
  const tools::KittiRoute route =
      tools::kittiRoute(eval::readKittiPoses(poses_path), route_options);
  const std::string problem = options.validate();
  if (!problem.empty()) {
    std::fprintf(stderr, "lcd_bench_pose_graph: %s\n", problem.c_str());
    return 2;
  }
  PoseGraph graph(options);
  std::vector<double> times;
  size_t next_loop = 0;
  for (size_t i = 0; i < route.truth.size(); ++i) {
    graph.addKeyframe(i, route.odometry[i]);
    bool new_loop = false;
    while (next_loop < route.loops.size() && route.loops[next_loop].query_id == i) {
      const LoopVerdict verdict = graph.addLoop(route.loops[next_loop]);
      new_loop |= verdict.decision == LoopDecision::kAccepted || !verdict.confirmed.empty();
      ++next_loop;
    }
    if (new_loop) times.push_back(graph.optimise().milliseconds);
  }
  std::vector<Pose> corrected;
  for (size_t i = 0; i < route.truth.size(); ++i) corrected.push_back(*graph.optimisedPose(i));
  size_t wrong = 0, wrong_accepted = 0, right_refused = 0;
  for (size_t k = 0; k < route.loops.size(); ++k) {
    const bool accepted = graph.loopVerdicts()[k].decision == LoopDecision::kAccepted;
    wrong += route.wrong[k] ? 1 : 0;
    wrong_accepted += route.wrong[k] && accepted ? 1 : 0;
    if (route.wrong[k] && accepted) {
      const LoopConstraint& loop = route.loops[k];
      const Eigen::Isometry3d claimed =
          route.truth[loop.query_id].toIsometry() * loop.query_T_match;
      std::printf(
          "  wrong loop %lu -> %lu accepted: the match is %.2f m from where the loop puts "
          "it, %.1f deg; %s\n",
          static_cast<unsigned long>(loop.query_id), static_cast<unsigned long>(loop.match_id),
          (claimed.translation() - route.truth[loop.match_id].position).norm(),
          Eigen::AngleAxisd(claimed.rotation().transpose() *
                            route.truth[loop.match_id].toIsometry().rotation())
                  .angle() *
              180.0 / M_PI,
          graph.loopVerdicts()[k].detail.c_str());
    }
    right_refused += !route.wrong[k] && !accepted ? 1 : 0;
  }
  const eval::TrajectoryError raw = eval::trajectoryError(route.odometry, route.truth);
  const eval::TrajectoryError fixed = eval::trajectoryError(corrected, route.truth);
  const eval::Percentiles time = eval::percentiles(times);
  std::printf(
      "%s: keyframes %zu, loops %zu (%zu wrong, %zu of them accepted; %zu true refused); "
      "max_loop_error_sd %.2f loop_loss_scale %.2f loop_confirmations %d within %.1f m; RMSE "
      "first pose aligned odometry %.3f m, "
      "corrected %.3f m; similarity-aligned %.3f m, %.3f m; optimisation median %.2f ms, p99 "
      "%.2f ms; heading drift estimated %.5f rad/m (prior sd %g)\n",
      poses_path.c_str(), route.truth.size(), route.loops.size(), wrong, wrong_accepted,
      right_refused, options.max_loop_error_sd, options.loop_loss_scale, options.loop_confirmations,
      options.confirmation_distance_m, raw.first_pose_rmse, fixed.first_pose_rmse,
      raw.similarity_rmse, fixed.similarity_rmse, time.median, time.p99,
      graph.headingDriftPerMetre(), options.heading_drift_prior_sd_per_m);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  size_t keyframes = 473;
  size_t timed = 100;
  size_t every = 10;
  std::string kitti_poses;
  tools::KittiRouteOptions route;
  PoseGraphOptions options;
  CLI::App app{
      "Pose-graph optimisation time per loop on the corridor's laps, or the graph's corrections "
      "on a KITTI route with simulated odometry error and wrong loops (--kitti)."};
  app.add_option("--keyframes", keyframes, "corridor: keyframes driven")->capture_default_str();
  app.add_option("--timed", timed, "corridor: the last loops, each optimised and timed")
      ->capture_default_str();
  app.add_option("--every", every, "corridor: loops between optimisations before those")
      ->capture_default_str();
  app.add_option("--kitti", kitti_poses, "KITTI poses file: run its route instead");
  app.add_option("--wrong-loops", route.wrong_fraction, "KITTI: wrong loops, as a fraction")
      ->capture_default_str();
  app.add_option("--seed", route.seed, "KITTI: random seed")->capture_default_str();
  app.add_option("--scale-error", route.scale_error, "KITTI: odometry scale error")
      ->capture_default_str();
  app.add_option("--heading-error", route.heading_error_per_m,
                 "KITTI: odometry heading error, rad a metre")
      ->capture_default_str();
  app.add_option("--heading-error-walk", route.heading_error_walk,
                 "KITTI: random walk of the heading error")
      ->capture_default_str();
  app.add_option("--turn-error", route.turn_error, "KITTI: odometry turn error per radian turned")
      ->capture_default_str();
  app.add_option("--max-loop-error-sd", options.max_loop_error_sd, "pose graph's parameter")
      ->capture_default_str();
  app.add_option("--loop-loss-scale", options.loop_loss_scale, "pose graph's parameter")
      ->capture_default_str();
  app.add_option("--heading-drift-prior-sd", options.heading_drift_prior_sd_per_m,
                 "pose graph's parameter")
      ->capture_default_str();
  app.add_option("--loop-confirmations", options.loop_confirmations, "pose graph's parameter")
      ->capture_default_str();
  app.add_option("--confirmation-distance", options.confirmation_distance_m,
                 "pose graph's parameter")
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  if (!kitti_poses.empty()) return runKitti(kitti_poses, route, options);
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
