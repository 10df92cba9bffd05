#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <gtest/gtest.h>

#include "../../fuzz/pose_graph_input.h"
#include "driven_loops.h"
#include "kept_fuzz_inputs.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"
#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/sim/driven_laps.h"

namespace landmark_loop_closure {
namespace {

using test_support::trueLoop;

using Drive = sim::DrivenLaps;

Drive driveLaps(int laps) {
  sim::DrivenLapsOptions options;
  options.laps = laps;
  return sim::driveLaps(options);
}

double positionRmse(const std::vector<Pose>& truth, const std::vector<Pose>& estimate) {
  double sum = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    sum += (truth[i].position - estimate[i].position).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(truth.size()));
}

std::vector<Pose> optimisedPoses(const PoseGraph& graph) {
  std::vector<Pose> poses;
  for (uint64_t id : graph.ids()) poses.push_back(*graph.optimisedPose(id));
  return poses;
}

/// Feeds the drive keyframe by keyframe, a loop (optimised at once) wherever the second lap is
/// within 0.3 m of a first-lap keyframe; every `wrong_every`-th loop names a random first-lap
/// keyframe instead, with the relative pose the right one would have had.
struct FeedCounts {
  size_t loops = 0;
  size_t wrong = 0;
  size_t wrong_refused = 0;
  size_t right_refused = 0;
};

FeedCounts feed(PoseGraph* graph, const Drive& drive, int wrong_every) {
  FeedCounts run;
  const size_t lap = drive.truth.size() / 2;
  std::mt19937 random(11);
  std::uniform_int_distribution<size_t> any_first_lap(0, lap - 40);
  for (size_t i = 0; i < drive.truth.size(); ++i) {
    EXPECT_EQ(graph->addKeyframe(i, drive.odometry[i]), "");
    if (i < lap + 5) continue;
    const size_t match = i - lap;
    if ((drive.truth[i].position - drive.truth[match].position).norm() > 0.3) continue;
    ++run.loops;
    LoopConstraint loop = trueLoop(drive, i, match);
    const bool wrong = wrong_every > 0 && run.loops % wrong_every == 0;
    if (wrong) {
      size_t other = any_first_lap(random);
      while ((drive.truth[other].position - drive.truth[match].position).norm() < 2.0) {
        other = any_first_lap(random);
      }
      loop.match_id = other;
      ++run.wrong;
    }
    graph->addLoop(loop);
    graph->optimise();
  }
  // Refused when they came, or switched off by a later optimisation.
  size_t index = 0;
  for (const LoopVerdict& verdict : graph->loopVerdicts()) {
    const bool wrong = wrong_every > 0 && (index + 1) % wrong_every == 0;
    const bool refused = verdict.decision != LoopDecision::kAccepted;
    if (wrong && refused) ++run.wrong_refused;
    if (!wrong && refused) ++run.right_refused;
    ++index;
  }
  return run;
}

/// The drive's odometry errs per turn, as the odometry model's per-radian term describes; with
/// the drift rate not estimated (how an error per turn fares with it: below).
PoseGraphOptions perTurnModel() {
  PoseGraphOptions options;
  options.heading_drift_prior_sd_per_m = 0.0;
  return options;
}

TEST(PoseGraph, LoopsBringADriftingSecondLapOntoTheFirst) {
  const Drive drive = driveLaps(2);
  PoseGraph graph(perTurnModel());
  const FeedCounts run = feed(&graph, drive, 0);
  const double odometry_rmse = positionRmse(drive.truth, drive.odometry);
  const double corrected_rmse = positionRmse(drive.truth, optimisedPoses(graph));
  EXPECT_GT(run.loops, 30u);
  EXPECT_EQ(run.right_refused, 0u);
  EXPECT_GT(odometry_rmse, 0.5);
  EXPECT_LT(corrected_rmse, 0.10) << "odometry " << odometry_rmse;
}

// A graph that takes over from another (the detector reset or switched maps) starts where the
// old one's correction left the odometry, and keeps it while loops correct the drift.
TEST(PoseGraph, AGraphBuiltWithACorrectionStartsFromIt) {
  const Drive drive = driveLaps(2);
  const Eigen::Isometry3d correction = planarPose(0.4, -0.3, 0.2).toIsometry();
  PoseGraph graph(perTurnModel(), correction);
  EXPECT_TRUE(graph.mapFromOdometry().isApprox(correction));
  const FeedCounts run = feed(&graph, drive, 0);
  EXPECT_EQ(run.right_refused, 0u);
  // The held first keyframe is the correction of its odometry; the rest follow the loops, so the
  // corrected drive is the truth moved rigidly by the correction.
  const Pose first = *graph.optimisedPose(0);
  EXPECT_TRUE(first.toIsometry().isApprox(correction * drive.odometry[0].toIsometry(), 1e-9));
  std::vector<Pose> truth_moved;
  for (const Pose& pose : drive.truth) {
    truth_moved.push_back(Pose::fromIsometry(correction * pose.toIsometry()));
  }
  EXPECT_LT(positionRmse(truth_moved, optimisedPoses(graph)), 0.10);
}

TEST(PoseGraph, WrongLoopsAreRefusedAndTheMapHolds) {
  const Drive drive = driveLaps(2);
  PoseGraph graph(perTurnModel());
  const FeedCounts run = feed(&graph, drive, 5);
  const double corrected_rmse = positionRmse(drive.truth, optimisedPoses(graph));
  EXPECT_GE(run.wrong, 6u);
  EXPECT_EQ(run.wrong_refused, run.wrong);
  EXPECT_LE(run.right_refused, run.loops / 10);
  EXPECT_LT(corrected_rmse, 0.20);
}

TEST(PoseGraph, AWrongFirstLoopIsRefusedByTheOdometry) {
  const Drive drive = driveLaps(2);
  PoseGraph graph;
  for (size_t i = 0; i < drive.truth.size(); ++i) graph.addKeyframe(i, drive.odometry[i]);
  const size_t last = drive.truth.size() - 1;
  LoopConstraint loop = trueLoop(drive, last, 40);  // 40 is across the rectangle from the end.
  loop.query_T_match = Eigen::Isometry3d::Identity();
  const LoopVerdict verdict = graph.addLoop(loop);
  EXPECT_EQ(verdict.decision, LoopDecision::kInconsistent) << verdict.detail;
  EXPECT_FALSE(graph.optimise().ran);  // Nothing to optimise: no loop entered.
}

/// Laps driven with odometry whose heading also drifts `drift_per_m` radians per metre
/// travelled (as visual odometry does), besides its error per turn and its noise.
Drive driftingLaps(double drift_per_m, double turn_error) {
  sim::DrivenLapsOptions options;
  options.turn_error = turn_error;
  Drive drive = sim::driveLaps(options);
  Eigen::Isometry3d odometry = drive.odometry.front().toIsometry();
  std::vector<Pose> drifting = {drive.odometry.front()};
  for (size_t i = 1; i < drive.odometry.size(); ++i) {
    Eigen::Isometry3d step =
        drive.odometry[i - 1].toIsometry().inverse() * drive.odometry[i].toIsometry();
    step.linear() =
        Eigen::AngleAxisd(drift_per_m * step.translation().norm(), Eigen::Vector3d::UnitZ()) *
        step.linear();
    odometry = odometry * step;
    drifting.push_back(Pose::fromIsometry(odometry));
  }
  drive.odometry = drifting;
  return drive;
}

TEST(PoseGraph, ASteadyHeadingDriftIsEstimatedAndTakenOutEverywhere) {
  const Drive drive = driftingLaps(0.004, 0.0);
  PoseGraph fixed_model(perTurnModel());
  feed(&fixed_model, drive, 0);
  PoseGraph drift_model;  // The defaults estimate the drift.
  const FeedCounts run = feed(&drift_model, drive, 0);
  EXPECT_EQ(run.right_refused, 0u);
  // Part of the lap's heading error is put on the turning edges (their odometry model is less
  // certain per radian turned), so the rate comes out somewhat low.
  EXPECT_NEAR(drift_model.headingDriftPerMetre(), 0.0035, 0.0007);
  EXPECT_DOUBLE_EQ(fixed_model.headingDriftPerMetre(), 0.0);
  // The first keyframes, which no loop reaches (feed starts at the second lap's sixth), are
  // placed again with the drift taken out, so the whole map is not turned about the start.
  const double odometry_rmse = positionRmse(drive.truth, drive.odometry);
  const double fixed_rmse = positionRmse(drive.truth, optimisedPoses(fixed_model));
  const double drift_rmse = positionRmse(drive.truth, optimisedPoses(drift_model));
  EXPECT_GT(odometry_rmse, 0.5);
  EXPECT_LT(drift_rmse, 0.08) << "without the drift estimated " << fixed_rmse;
  EXPECT_LT(drift_rmse, 0.5 * fixed_rmse);
}

TEST(PoseGraph, AnErrorPerTurnOnOneCircuitPassesForADriftWithinBounds) {
  // The default drive's odometry errs by 3 % per turn and does not drift per metre. Loops
  // between two laps of one circuit see the lap's whole heading error, not how it is spread
  // along the lap, so the graph takes part of it for a drift: the map stays within bounds and
  // the wrong loops are still refused.
  const Drive drive = driftingLaps(0.0, 0.03);
  PoseGraph fixed_model(perTurnModel());
  feed(&fixed_model, drive, 5);
  PoseGraph drift_model;
  const FeedCounts run = feed(&drift_model, drive, 5);
  EXPECT_EQ(run.wrong_refused, run.wrong);
  EXPECT_GT(run.wrong, 5u);
  const double fixed_rmse = positionRmse(drive.truth, optimisedPoses(fixed_model));
  const double drift_rmse = positionRmse(drive.truth, optimisedPoses(drift_model));
  EXPECT_LT(drift_rmse, 0.2) << "drift estimated " << drift_model.headingDriftPerMetre()
                             << ", without it " << fixed_rmse;
}

/// The drive with every keyframe in the graph and no loop yet.
void addAllKeyframes(PoseGraph* graph, const Drive& drive) {
  for (size_t i = 0; i < drive.truth.size(); ++i) {
    ASSERT_EQ(graph->addKeyframe(i, drive.odometry[i]), "");
  }
}

TEST(PoseGraph, ATrueLoopWaitsForTheNextOneOfItsRevisitThenBothEnter) {
  const Drive drive = driveLaps(2);
  const size_t lap = drive.truth.size() / 2;
  PoseGraph graph;  // The defaults ask one other loop nearby to agree.
  addAllKeyframes(&graph, drive);
  const LoopVerdict first = graph.addLoop(trueLoop(drive, lap + 5, 5));
  EXPECT_EQ(first.decision, LoopDecision::kAwaitingConfirmation) << first.detail;
  EXPECT_EQ(graph.activeLoops(), 0u);
  EXPECT_FALSE(graph.optimise().ran);
  const LoopVerdict second = graph.addLoop(trueLoop(drive, lap + 6, 6));
  EXPECT_EQ(second.decision, LoopDecision::kAccepted) << second.detail;
  EXPECT_EQ(second.confirmed, std::vector<size_t>{0});
  EXPECT_EQ(graph.loopVerdicts()[0].decision, LoopDecision::kAccepted);
  EXPECT_NE(graph.loopVerdicts()[0].detail.find("confirmed by loop 1"), std::string::npos);
  EXPECT_EQ(graph.activeLoops(), 2u);
  EXPECT_TRUE(graph.optimise().ran);

  // The same query matched twice is one observation; a loop further along than
  // confirmation_distance_m is no partner.
  PoseGraph alone;
  addAllKeyframes(&alone, drive);
  alone.addLoop(trueLoop(drive, lap + 5, 5));
  EXPECT_EQ(alone.addLoop(trueLoop(drive, lap + 5, 6)).decision,
            LoopDecision::kAwaitingConfirmation);
  const double metres_apart = 25 * sim::DrivenLapsOptions{}.step;  // Along the odometry.
  ASSERT_GT(metres_apart, PoseGraphOptions{}.confirmation_distance_m);
  EXPECT_EQ(alone.addLoop(trueLoop(drive, lap + 30, 30)).decision,
            LoopDecision::kAwaitingConfirmation);
  EXPECT_EQ(alone.activeLoops(), 0u);
}

TEST(PoseGraph, ALoopTheDriftingOdometryRefusesStillConfirmsItsNeighbour) {
  const Drive drive = driveLaps(2);  // Its odometry errs 3 % per turn.
  const size_t lap = drive.truth.size() / 2;
  // An odometry model far more certain than the drive's odometry: true loops fail the screening
  // unless their own covariance is loose.
  PoseGraphOptions tight = perTurnModel();
  tight.odometry_rotation_sd_per_m = 0.0;
  tight.odometry_rotation_sd_per_rad = 0.001;
  PoseGraph graph(tight);
  addAllKeyframes(&graph, drive);
  LoopConstraint loose = trueLoop(drive, lap + 5, 5);
  loose.covariance.diagonal() << 1.0, 1.0, 1.0, 0.1, 0.1, 0.1;
  const LoopVerdict waiting = graph.addLoop(loose);
  ASSERT_EQ(waiting.decision, LoopDecision::kAwaitingConfirmation) << waiting.detail;
  const LoopVerdict refused = graph.addLoop(trueLoop(drive, lap + 6, 6));
  ASSERT_EQ(refused.decision, LoopDecision::kInconsistent) << refused.detail;
  // The pair test does not use the long odometry path that refused it.
  EXPECT_EQ(refused.confirmed, std::vector<size_t>{0});
  EXPECT_EQ(graph.loopVerdicts()[0].decision, LoopDecision::kAccepted);
  EXPECT_EQ(graph.activeLoops(), 1u);
}

TEST(PoseGraph, AWrongLoopTheOdometryCannotTellIsKeptOutByTheLoopsBesideIt) {
  const Drive drive = driveLaps(2);
  const size_t lap = drive.truth.size() / 2;
  // An odometry model too loose to tell a match 4 m along the first lap from the right one.
  PoseGraphOptions loose = perTurnModel();
  loose.odometry_rotation_sd_per_m = 0.05;
  for (const int confirmations : {0, 1}) {
    loose.loop_confirmations = confirmations;
    PoseGraph graph(loose);
    addAllKeyframes(&graph, drive);
    LoopConstraint wrong = trueLoop(drive, lap + 5, 5);
    wrong.match_id = 13;
    const LoopVerdict verdict = graph.addLoop(wrong);
    size_t true_loops = 0;
    for (size_t query = lap + 6; query <= lap + 16; ++query) {
      if ((drive.truth[query].position - drive.truth[query - lap].position).norm() > 0.3) continue;
      graph.addLoop(trueLoop(drive, query, query - lap));
      ++true_loops;
    }
    graph.optimise();
    ASSERT_GT(true_loops, 5u);
    if (confirmations == 0) {
      // The screening alone lets it in (the optimised graph may switch it off later).
      EXPECT_EQ(verdict.decision, LoopDecision::kAccepted) << verdict.detail;
    } else {
      EXPECT_EQ(verdict.decision, LoopDecision::kAwaitingConfirmation) << verdict.detail;
      EXPECT_EQ(graph.loopVerdicts()[0].decision, LoopDecision::kAwaitingConfirmation);
      EXPECT_EQ(graph.activeLoops(), true_loops);
    }
  }
}

TEST(PoseGraph, BadInputIsRefusedAndNamed) {
  PoseGraph graph;
  EXPECT_EQ(graph.addKeyframe(3, planarPose(0, 0, 0)), "");
  EXPECT_NE(graph.addKeyframe(3, planarPose(1, 0, 0)), "");
  Pose broken = planarPose(1, 0, 0);
  broken.position.x() = std::nan("");
  EXPECT_NE(graph.addKeyframe(4, broken), "");
  // Finite, but its distance to the last keyframe overflows when squared (found by fuzzing: the
  // estimates became NaN and Ceres aborted at the next optimisation).
  Pose far = planarPose(1, 0, 0);
  far.position.x() = 5e173;
  EXPECT_NE(graph.addKeyframe(4, far).find("more than 1e+09 m from"), std::string::npos);
  EXPECT_EQ(graph.addKeyframe(5, planarPose(1, 0, 0)), "");
  EXPECT_EQ(graph.keyframes(), 2u);

  LoopConstraint unknown;
  unknown.query_id = 5;
  unknown.match_id = 4;
  EXPECT_EQ(graph.addLoop(unknown).decision, LoopDecision::kUnknownKeyframe);
  LoopConstraint singular;
  singular.query_id = 5;
  singular.match_id = 3;
  singular.covariance.setZero();
  EXPECT_EQ(graph.addLoop(singular).decision, LoopDecision::kBadCovariance);
  LoopConstraint not_turned = singular;
  not_turned.covariance.setIdentity();
  for (const double scale : {0.0, 4.0, std::nan("")}) {
    not_turned.query_T_match.linear() = scale * Eigen::Matrix3d::Identity();
    EXPECT_EQ(graph.addLoop(not_turned).decision, LoopDecision::kBadPose) << scale;
  }
  not_turned.query_T_match.linear() = Eigen::Vector3d(1, 1, -1).asDiagonal();  // A mirror.
  EXPECT_EQ(graph.addLoop(not_turned).decision, LoopDecision::kBadPose);
  not_turned.query_T_match.linear().setIdentity();
  not_turned.query_T_match.translation().x() = std::nan("");
  EXPECT_EQ(graph.addLoop(not_turned).decision, LoopDecision::kBadPose);
  EXPECT_EQ(graph.activeLoops(), 0u);

  PoseGraphOptions options;
  options.max_loop_error_sd = -1.0;
  EXPECT_NE(options.validate().find("pose_graph/max_loop_error_sd"), std::string::npos);
  EXPECT_THROW(PoseGraph{options}, std::invalid_argument);
}

// Loops the screening cannot judge sensibly - a keyframe to itself, half-turns, 1e5 m away,
// covariances of 1e-18 and 1e18 - on routes far from the origin, with 1 km steps or none: the
// graph may refuse or keep them, but every estimate, map -> odom and the drift stay finite.
TEST(PoseGraph, ExtremeButWellFormedInputKeepsEveryEstimateFinite) {
  size_t optimised_with_loops = 0;
  for (int seed = 0; seed < 24; ++seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    PoseGraphOptions options;
    options.loop_confirmations = seed % 3;
    PoseGraph graph(options);
    const double offset = seed % 4 == 0 ? 1e6 : 0.0;
    const double step = seed % 5 == 0 ? 0.0 : (seed % 7 == 0 ? 1000.0 : 0.1);
    const size_t count = 40 + static_cast<size_t>(seed) * 3;
    for (size_t i = 0; i < count; ++i) {
      ASSERT_EQ(graph.addKeyframe(i, planarPose(offset + step * static_cast<double>(i), 0.0,
                                                0.3 * std::sin(0.1 * static_cast<double>(i)))),
                "");
    }
    for (int k = 0; k < 40; ++k) {
      LoopConstraint loop;
      loop.query_id = static_cast<uint64_t>(unit(random) * static_cast<double>(count));
      loop.match_id = k % 10 == 0
                          ? loop.query_id
                          : static_cast<uint64_t>(unit(random) * static_cast<double>(count));
      loop.query_T_match.translation() =
          Eigen::Vector3d(unit(random), unit(random), 0.0) * (k % 6 == 0 ? 1e5 : 1.0);
      loop.query_T_match.linear() =
          Eigen::AngleAxisd(k % 4 == 0 ? M_PI : unit(random), Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
      const double sd = k % 5 == 0 ? 1e-9 : (k % 5 == 1 ? 1e9 : 0.05);
      loop.covariance = Eigen::Matrix<double, 6, 6>::Identity() * sd * sd;
      graph.addLoop(loop);
      if (k % 3 == 0) graph.optimise();
    }
    graph.optimise();
    EXPECT_EQ(graph.loopVerdicts().size(), 40u);
    if (graph.activeLoops() > 0) ++optimised_with_loops;
    for (uint64_t id : graph.ids()) {
      const Pose pose = *graph.optimisedPose(id);
      ASSERT_TRUE(pose.position.allFinite() && pose.orientation.coeffs().allFinite())
          << "seed " << seed << ", keyframe " << id;
    }
    ASSERT_TRUE(graph.mapFromOdometry().matrix().allFinite()) << "seed " << seed;
    ASSERT_TRUE(std::isfinite(graph.headingDriftPerMetre())) << "seed " << seed;
  }
  EXPECT_GT(optimised_with_loops, 12u) << "the graphs must have solved with such loops in them";
}

TEST(PoseGraph, ACameraFrameLoopTurnsIntoTheBaseFrameWithItsCovariance) {
  Eigen::Isometry3d base_T_camera = Eigen::Isometry3d::Identity();
  base_T_camera.translate(Eigen::Vector3d(0.3, -0.1, 0.5));
  base_T_camera.rotate(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()));
  LoopConstraint camera;
  camera.query_T_match.translate(Eigen::Vector3d(0.2, 0.1, 1.0));
  camera.query_T_match.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()));
  const LoopConstraint base = loopInBaseFrame(camera, base_T_camera);
  // The same motion of the robot, seen from either frame.
  const Eigen::Isometry3d expected = base_T_camera * camera.query_T_match * base_T_camera.inverse();
  EXPECT_TRUE(base.query_T_match.isApprox(expected, 1e-12));
  // The covariance's first-order map checked against finite differences of the frame change.
  Eigen::Matrix<double, 6, 6> numeric;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
    delta[k] = h;
    Eigen::Isometry3d moved = camera.query_T_match;
    moved.translation() += delta.head<3>();
    moved.linear() = Eigen::AngleAxisd(delta.tail<3>().norm(), delta.tail<3>().norm() > 0
                                                                   ? delta.tail<3>().normalized()
                                                                   : Eigen::Vector3d::UnitX())
                         .toRotationMatrix() *
                     camera.query_T_match.linear();
    const Eigen::Isometry3d moved_base = base_T_camera * moved * base_T_camera.inverse();
    numeric.block<3, 1>(0, k) = (moved_base.translation() - expected.translation()) / h;
    const Eigen::AngleAxisd turn(moved_base.linear() * expected.linear().transpose());
    numeric.block<3, 1>(3, k) = turn.axis() * turn.angle() / h;
  }
  camera.covariance = Eigen::Matrix<double, 6, 6>::Identity();
  const LoopConstraint unit = loopInBaseFrame(camera, base_T_camera);
  EXPECT_TRUE(unit.covariance.isApprox(numeric * numeric.transpose(), 1e-4))
      << unit.covariance << "\n\n"
      << numeric * numeric.transpose();
}

TEST(PoseGraphConfig, ShippedFilesLoadAndTheDefaultsAreWhatTheDeclarationsRender) {
  namespace fs = std::filesystem;
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(PACKAGE_SOURCE_DIR) / "config")) {
    if (entry.path().filename().string().rfind("pose_graph", 0) != 0) continue;
    SCOPED_TRACE(entry.path().string());
    ++files;
    const YamlParameterSource source = YamlParameterSource::fromFile(entry.path().string());
    OptionReader reader(source);
    PoseGraphNodeOptions options;
    PoseGraphNodeOptions::parameters().read(&reader, &options);
    EXPECT_EQ(reader.errors(), "");
    EXPECT_EQ(options.validate(), "");
    for (const std::string& key : source.keys()) EXPECT_TRUE(reader.isKnown(key)) << key;
  }
  EXPECT_GE(files, 1u);
  std::ifstream file(std::string(PACKAGE_SOURCE_DIR) + "/config/pose_graph.yaml");
  const std::string shipped((std::istreambuf_iterator<char>(file)),
                            std::istreambuf_iterator<char>());
  EXPECT_EQ(shipped, poseGraphDefaultsYaml())
      << "config/pose_graph.yaml differs from the declarations; regenerate it with\n"
         "  rosrun landmark_loop_closure lcd_config pose_graph_defaults > config/pose_graph.yaml";
}

TEST(TrajectoryError, AScaleDriftShowsInTheFirstPoseFitOnly) {
  const Drive drive = driveLaps(1);
  std::vector<Pose> scaled = drive.truth;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translate(Eigen::Vector3d(2.0, -1.0, 0.5));
  offset.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  for (Pose& pose : scaled) {
    pose.position *= 1.02;
    pose = Pose::fromIsometry(offset * pose.toIsometry());
  }
  const eval::TrajectoryError error = eval::trajectoryError(scaled, drive.truth);
  EXPECT_GT(error.first_pose_rmse, 0.05);  // 2 % of a 10 m x 6 m rectangle.
  EXPECT_LT(error.similarity_rmse, 1e-9);
  EXPECT_NEAR(error.scale, 1.0 / 1.02, 1e-9);
  EXPECT_LT(eval::trajectoryError(drive.truth, drive.truth).first_pose_rmse, 1e-12);
  EXPECT_EQ(eval::trajectoryError({}, {}).first_pose_rmse, -1.0);
}

TEST(PoseGraphReplay, TheDetectorsMetricLoopsCorrectItsKeyframesAndWrongOnesAreCounted) {
  const Drive drive = driftingLaps(0.004, 0.0);
  eval::DetectorEvaluation evaluation;
  evaluation.keyframe_poses = drive.odometry;
  const size_t lap = drive.keyframes_per_lap;
  for (size_t i = lap + 5; i < drive.truth.size(); i += 3) {
    eval::PublishedLoop loop;
    loop.query_id = i;
    loop.match_id = i - lap;
    loop.correct = true;
    loop.metric_pose = trueLoop(drive, i, i - lap);
    if (i == lap + 35) {  // A wrong one: another place, the pose of the right one.
      loop.match_id = 40;
      loop.metric_pose->match_id = 40;
      loop.correct = false;
    }
    evaluation.configured.loops.push_back(loop);
  }
  evaluation.configured.loops.push_back(eval::PublishedLoop{});  // No pose: not given.
  const eval::PoseGraphReplay replay = eval::replayIntoPoseGraph(evaluation);
  EXPECT_EQ(replay.metric_loops, evaluation.configured.loops.size() - 1);
  EXPECT_EQ(replay.refused_loops, 1u);
  EXPECT_EQ(replay.refused_true_loops, 0u);
  ASSERT_EQ(replay.corrected.size(), drive.truth.size());
  EXPECT_LT(eval::trajectoryError(replay.corrected, drive.truth).first_pose_rmse, 0.10);
  EXPECT_GT(eval::trajectoryError(drive.odometry, drive.truth).first_pose_rmse, 0.5);
}

TEST(PoseGraph, EveryKeptFuzzInputLeavesFiniteEstimates) {
  const std::vector<KeptFuzzInput> inputs = keptFuzzInputs("fuzz_pose_graph");
  for (const KeptFuzzInput& input : inputs) {
    SCOPED_TRACE(input.path.string());
    EXPECT_TRUE(fuzz::replayPoseGraphInput(input.bytes.data(), input.bytes.size()));
  }
  EXPECT_GE(inputs.size(), 3u);
}

}  // namespace
}  // namespace landmark_loop_closure
