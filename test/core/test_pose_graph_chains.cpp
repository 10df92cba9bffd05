// The pose graph of several odometry chains (issue 68): a run whose odometry frame is another (a
// new session, another robot) is a chain of its own that floats until loops join it; then it is
// moved onto them and optimised with the rest. Chains may interleave (robots sharing one graph).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "driven_loops.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/sim/driven_laps.h"

namespace landmark_loop_closure {
namespace {

using test_support::trueLoop;

/// Two laps of the rectangle: the first in odometry frame A (chain 0), the second in a frame B
/// the odometry re-initialised into, far from A (40 m, -25 m, turned 90 degrees).
struct TwoRuns {
  sim::DrivenLaps drive;
  size_t lap = 0;                     ///< Keyframes of the first lap.
  std::vector<Pose> second_odometry;  ///< The second lap in frame B.
};

TwoRuns twoRuns() {
  TwoRuns runs;
  sim::DrivenLapsOptions options;
  options.laps = 2;
  runs.drive = sim::driveLaps(options);
  runs.lap = runs.drive.truth.size() / 2;
  const Eigen::Isometry3d frame_b = Eigen::Translation3d(40.0, -25.0, 0.0) *
                                    Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d rebase = runs.drive.odometry[runs.lap].toIsometry().inverse();
  for (size_t i = runs.lap; i < runs.drive.truth.size(); ++i) {
    runs.second_odometry.push_back(
        Pose::fromIsometry(frame_b * rebase * runs.drive.odometry[i].toIsometry()));
  }
  return runs;
}

/// How far the second lap's keyframes lie from where the first lap's estimate puts the same
/// places (RMS, metres): the first lap keeps its own odometry drift (no loop corrects it), the
/// second must lie on it. `second_lap` gives the graph id of the second lap's keyframe j.
template <typename SecondLapId>
double offFirstLap(const PoseGraph& graph, const TwoRuns& runs, SecondLapId second_lap) {
  double sum = 0.0;
  for (size_t j = 0; j < runs.lap; ++j) {
    const Eigen::Vector3d truly =
        runs.drive.truth[runs.lap + j].position - runs.drive.truth[j].position;
    const Eigen::Vector3d estimated =
        graph.optimisedPose(second_lap(j))->position - graph.optimisedPose(j)->position;
    sum += (estimated - truly).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(runs.lap));
}

PoseGraphOptions options() {
  PoseGraphOptions graph_options;
  graph_options.heading_drift_prior_sd_per_m = 0.0;  // The drive errs per turn.
  return graph_options;
}

/// Keyframe i of the second lap gets a loop to the first lap's keyframe at the same place (every
/// third one, from the fifth on); accepted loops are optimised at once.
size_t closeLoops(PoseGraph* graph, const TwoRuns& runs, size_t i) {
  const size_t match = i - runs.lap;
  if (match < 5 || match % 3 != 0) return 0;
  const LoopVerdict verdict = graph->addLoop(trueLoop(runs.drive, i, match));
  if (verdict.decision == LoopDecision::kAccepted || !verdict.confirmed.empty()) {
    graph->optimise();
  }
  return 1;
}

TEST(PoseGraphChains, ASecondOdometryFrameFloatsUntilLoopsJoinItThenLiesOnTheFirst) {
  const TwoRuns runs = twoRuns();
  PoseGraph graph(options());
  for (size_t i = 0; i < runs.lap; ++i) ASSERT_EQ(graph.addKeyframe(i, runs.drive.odometry[i]), "");
  // Placed at frame B's own origin: wrong by tens of metres, as a real re-initialisation is.
  ASSERT_EQ(graph.startChain(runs.lap, runs.second_odometry[0], Eigen::Isometry3d::Identity()), "");
  EXPECT_EQ(graph.chains(), 2u);
  EXPECT_EQ(*graph.chainOf(runs.lap), 1u);
  EXPECT_EQ(*graph.chainOf(0), 0u);
  size_t loops = 0;
  std::optional<size_t> joined_at;
  for (size_t i = runs.lap + 1; i < runs.drive.truth.size(); ++i) {
    ASSERT_EQ(graph.addKeyframe(i, runs.second_odometry[i - runs.lap]), "");
    loops += closeLoops(&graph, runs, i);
    if (!joined_at && graph.chainsJoinedToFirst() == 2) joined_at = i;
  }
  ASSERT_TRUE(joined_at);
  // The first loop waits for a second that agrees with it (PCM across chains): none joins alone.
  EXPECT_GE(loops, 10u);
  for (const LoopVerdict& verdict : graph.loopVerdicts()) {
    EXPECT_EQ(verdict.decision, LoopDecision::kAccepted) << verdict.detail;
  }
  EXPECT_NE(graph.loopVerdicts()[0].detail.find("joins chain 1 to chain 0"), std::string::npos)
      << graph.loopVerdicts()[0].detail;
  // Both laps in one frame, the first lap's: the second on the first, within centimetres.
  EXPECT_LT(offFirstLap(graph, runs, [&runs](size_t j) { return runs.lap + j; }), 0.05);
  // map -> odom now takes frame B onto A, where the first lap's estimate put the place.
  const Eigen::Isometry3d b_to_a = graph.mapFromOdometry();
  const Eigen::Vector3d last = (b_to_a * runs.second_odometry.back().toIsometry()).translation();
  const Eigen::Vector3d truly =
      runs.drive.truth.back().position - runs.drive.truth[runs.lap - 1].position;
  EXPECT_LT((last - graph.optimisedPose(runs.lap - 1)->position - truly).norm(), 0.1);
}

TEST(PoseGraphChains, ALoopThatNoOtherConfirmsNeverMovesAFloatingChain) {
  const TwoRuns runs = twoRuns();
  PoseGraph graph(options());
  for (size_t i = 0; i < runs.lap; ++i) graph.addKeyframe(i, runs.drive.odometry[i]);
  graph.startChain(runs.lap, runs.second_odometry[0], Eigen::Isometry3d::Identity());
  for (size_t i = runs.lap + 1; i < runs.lap + 20; ++i) {
    graph.addKeyframe(i, runs.second_odometry[i - runs.lap]);
  }
  const Pose floating = *graph.optimisedPose(runs.lap + 10);
  // Two wrong loops (the relative pose of the right place, the id of another), each to another
  // wrong place: they do not agree with each other.
  LoopConstraint wrong = trueLoop(runs.drive, runs.lap + 10, 10);
  wrong.match_id = 30;
  LoopConstraint other_wrong = trueLoop(runs.drive, runs.lap + 12, 12);
  other_wrong.match_id = 45;
  EXPECT_EQ(graph.addLoop(wrong).decision, LoopDecision::kAwaitingConfirmation);
  EXPECT_EQ(graph.addLoop(other_wrong).decision, LoopDecision::kAwaitingConfirmation);
  graph.optimise();
  EXPECT_EQ(graph.chainsJoinedToFirst(), 1u);
  EXPECT_TRUE(graph.optimisedPose(runs.lap + 10)->position.isApprox(floating.position, 1e-9));
}

TEST(PoseGraphChains, OnceJoinedAWrongLoopBetweenTheChainsIsScreenedOut) {
  const TwoRuns runs = twoRuns();
  PoseGraph graph(options());
  for (size_t i = 0; i < runs.lap; ++i) graph.addKeyframe(i, runs.drive.odometry[i]);
  graph.startChain(runs.lap, runs.second_odometry[0], Eigen::Isometry3d::Identity());
  for (size_t i = runs.lap + 1; i < runs.drive.truth.size(); ++i) {
    graph.addKeyframe(i, runs.second_odometry[i - runs.lap]);
    closeLoops(&graph, runs, i);
  }
  ASSERT_EQ(graph.chainsJoinedToFirst(), 2u);
  // The last keyframe of the second lap said to be where the first lap was 10 keyframes in.
  const size_t query = runs.drive.truth.size() - 1;
  LoopConstraint wrong = trueLoop(runs.drive, query, 10);
  wrong.match_id = 30;
  EXPECT_EQ(graph.addLoop(wrong).decision, LoopDecision::kInconsistent);
}

// Two robots in one graph: their keyframes come interleaved, each robot's odometry edges join
// only its own keyframes.
TEST(PoseGraphChains, InterleavedChainsKeepTheirOwnOdometryEdges) {
  const TwoRuns runs = twoRuns();
  PoseGraph graph(options());
  uint64_t next_id = 0;
  std::vector<uint64_t> robot_a, robot_b;  // Graph ids, by keyframe of each lap.
  for (size_t j = 0; j < runs.lap; ++j) {
    const uint64_t a = next_id++;
    ASSERT_EQ(j == 0 ? graph.addKeyframe(a, runs.drive.odometry[j])
                     : graph.addToChain(0, a, runs.drive.odometry[j]),
              "");
    robot_a.push_back(a);
    const uint64_t b = next_id++;
    ASSERT_EQ(j == 0 ? graph.startChain(b, runs.second_odometry[j], Eigen::Isometry3d::Identity())
                     : graph.addToChain(1, b, runs.second_odometry[j]),
              "");
    robot_b.push_back(b);
    if (j >= 5 && j % 3 == 0) {
      LoopConstraint loop = trueLoop(runs.drive, runs.lap + j, j);
      loop.query_id = b;
      loop.match_id = a;
      const LoopVerdict verdict = graph.addLoop(loop);
      if (verdict.decision == LoopDecision::kAccepted || !verdict.confirmed.empty()) {
        graph.optimise();
      }
    }
  }
  EXPECT_EQ(graph.addToChain(2, next_id, runs.second_odometry[0]),
            "keyframe " + std::to_string(next_id) + ": chain 2 does not exist");
  ASSERT_EQ(graph.chainsJoinedToFirst(), 2u);
  for (size_t j = 0; j < runs.lap; ++j) EXPECT_EQ(*graph.chainOf(robot_b[j]), 1u);
  // offFirstLap reads robot A's keyframe j as graph id j: here it is robot_a[j].
  double sum = 0.0;
  for (size_t j = 0; j < runs.lap; ++j) {
    const Eigen::Vector3d truly =
        runs.drive.truth[runs.lap + j].position - runs.drive.truth[j].position;
    const Eigen::Vector3d estimated =
        graph.optimisedPose(robot_b[j])->position - graph.optimisedPose(robot_a[j])->position;
    sum += (estimated - truly).squaredNorm();
  }
  EXPECT_LT(std::sqrt(sum / static_cast<double>(runs.lap)), 0.05);
}

}  // namespace
}  // namespace landmark_loop_closure
