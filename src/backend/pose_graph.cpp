#include "landmark_loop_closure/backend/pose_graph.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

#include <ceres/ceres.h>

#include "landmark_loop_closure/common/stopwatch.h"

namespace landmark_loop_closure {
namespace {

/// A measured relative pose i -> j (x_i = R x_j + t), with the square root of its information.
struct RelativePoseMeasurement {
  RelativePoseMeasurement(const Eigen::Isometry3d& i_T_j,
                          const Eigen::Matrix<double, 6, 6>& sqrt_information_)
      : translation(i_T_j.translation()),
        rotation(Eigen::Quaterniond(i_T_j.rotation())),
        sqrt_information(sqrt_information_) {}

  /// The estimate's error against the measurement whose rotation is first turned by `turn`, in
  /// the measurement's convention (translation difference, then the rotation w with R_est =
  /// exp(w) R_meas, both in frame i), weighted.
  template <typename T>
  void error(const T* position_i, const T* orientation_i, const T* position_j,
             const T* orientation_j, const Eigen::Quaternion<T>& turn, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_i(position_i);
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(orientation_i);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_j(position_j);
    const Eigen::Map<const Eigen::Quaternion<T>> q_j(orientation_j);
    const Eigen::Quaternion<T> q_i_inverse = q_i.conjugate();
    const Eigen::Matrix<T, 3, 1> t_estimate = q_i_inverse * (p_j - p_i);
    const Eigen::Quaternion<T> q_estimate = q_i_inverse * q_j;
    const Eigen::Quaternion<T> difference =
        q_estimate * (turn * rotation.template cast<T>()).conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> weighted(residual);
    weighted.template head<3>() = t_estimate - translation.template cast<T>();
    weighted.template tail<3>() = T(2.0) * difference.vec();
    weighted.applyOnTheLeft(sqrt_information.template cast<T>());
  }

  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
  Eigen::Matrix<double, 6, 6> sqrt_information;
};

/// A loop, or an odometry step whose heading drift is not estimated.
class RelativePoseResidual {
 public:
  explicit RelativePoseResidual(const RelativePoseMeasurement& measured) : measured_(measured) {}

  template <typename T>
  bool operator()(const T* position_i, const T* orientation_i, const T* position_j,
                  const T* orientation_j, T* residual) const {
    measured_.error(position_i, orientation_i, position_j, orientation_j,
                    Eigen::Quaternion<T>::Identity(), residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& i_T_j,
                                     const Eigen::Matrix<double, 6, 6>& sqrt_information) {
    return new ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 3, 4, 3, 4>(
        new RelativePoseResidual({i_T_j, sqrt_information}));
  }

 private:
  RelativePoseMeasurement measured_;
};

/// The heading turned back by drift x distance before the odometry step is compared: the
/// odometry's rotation over the step is Rz(drift * metres) R_true.
Eigen::Quaterniond headingTurn(double radians) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitZ()));
}

/// An odometry step with the drift rate (one parameter) estimated.
class DriftingOdometryResidual {
 public:
  explicit DriftingOdometryResidual(const RelativePoseMeasurement& measured)
      : measured_(measured), metres_(measured.translation.norm()) {}

  template <typename T>
  bool operator()(const T* position_i, const T* orientation_i, const T* position_j,
                  const T* orientation_j, const T* drift_per_m, T* residual) const {
    const T half_turn = -T(0.5) * drift_per_m[0] * T(metres_);
    const Eigen::Quaternion<T> undo_drift(cos(half_turn), T(0), T(0), sin(half_turn));
    measured_.error(position_i, orientation_i, position_j, orientation_j, undo_drift, residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& i_T_j,
                                     const Eigen::Matrix<double, 6, 6>& sqrt_information) {
    return new ceres::AutoDiffCostFunction<DriftingOdometryResidual, 6, 3, 4, 3, 4, 1>(
        new DriftingOdometryResidual({i_T_j, sqrt_information}));
  }

 private:
  RelativePoseMeasurement measured_;
  double metres_;
};

/// The drift rate's prior: zero, with the configured standard deviation.
struct DriftPrior {
  double sd;
  template <typename T>
  bool operator()(const T* drift_per_m, T* residual) const {
    residual[0] = drift_per_m[0] / T(sd);
    return true;
  }
};

/// Upper-triangular S with S^T S = covariance^-1; nullopt when the covariance is unusable.
std::optional<Eigen::Matrix<double, 6, 6>> sqrtInformation(
    const Eigen::Matrix<double, 6, 6>& covariance) {
  if (!covariance.allFinite()) return std::nullopt;
  if ((covariance - covariance.transpose()).cwiseAbs().maxCoeff() >
      1e-9 * std::max(1.0, covariance.cwiseAbs().maxCoeff())) {
    return std::nullopt;
  }
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> covariance_llt(covariance);
  if (covariance_llt.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 6, 6> information =
      covariance_llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> information_llt(
      0.5 * (information + information.transpose()));
  if (information_llt.info() != Eigen::Success) return std::nullopt;
  return Eigen::Matrix<double, 6, 6>(information_llt.matrixL().transpose());
}

// A loop's rotation block may be this far from orthonormal (R^T R - I, largest entry): about a
// quaternion within 1e-3 of unit length, the keyframes' tolerance.
constexpr double kRotationTolerance = 5e-3;

double rotationAngle(const Eigen::Matrix3d& rotation) {
  return Eigen::AngleAxisd(rotation).angle();
}

}  // namespace

std::string toString(LoopDecision decision) {
  switch (decision) {
    case LoopDecision::kAccepted:
      return "accepted";
    case LoopDecision::kUnknownKeyframe:
      return "unknown_keyframe";
    case LoopDecision::kBadCovariance:
      return "bad_covariance";
    case LoopDecision::kBadPose:
      return "bad_pose";
    case LoopDecision::kInconsistent:
      return "inconsistent";
    case LoopDecision::kSwitchedOff:
      return "switched_off";
    case LoopDecision::kAwaitingConfirmation:
      return "awaiting_confirmation";
  }
  return "unknown";
}

LoopConstraint loopInBaseFrames(const LoopConstraint& camera_loop,
                                const Eigen::Isometry3d& query_base_T_camera,
                                const Eigen::Isometry3d& match_base_T_camera) {
  LoopConstraint loop = camera_loop;
  const BodyLoop body = loopBetweenBodies(camera_loop.query_T_match, camera_loop.covariance,
                                          query_base_T_camera, match_base_T_camera);
  loop.query_T_match = body.query_T_match;
  loop.covariance = body.covariance;
  return loop;
}

LoopConstraint loopInBaseFrame(const LoopConstraint& camera_loop,
                               const Eigen::Isometry3d& base_T_camera) {
  return loopInBaseFrames(camera_loop, base_T_camera, base_T_camera);
}

PoseGraph::PoseGraph(PoseGraphOptions options, const Eigen::Isometry3d& map_from_odometry)
    : options_(options), initial_map_from_odometry_(map_from_odometry) {
  const std::string problems = options_.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
}

PoseGraph::~PoseGraph() = default;

std::string PoseGraph::odometryPoseProblem(uint64_t id, const Pose& odometry_pose) {
  if (!odometry_pose.position.allFinite() || !odometry_pose.orientation.coeffs().allFinite() ||
      std::abs(odometry_pose.orientation.norm() - 1.0) > 1e-3) {
    return "keyframe " + std::to_string(id) + ": pose not finite or orientation not unit length";
  }
  // Its estimate would turn into NaN, which Ceres aborts on.
  if (odometry_pose.position.cwiseAbs().maxCoeff() > kMaxPoseCoordinateM) {
    std::ostringstream problem;
    problem << "keyframe " << id << ": position more than " << kMaxPoseCoordinateM
            << " m from the odometry's origin";
    return problem.str();
  }
  return "";
}

std::string PoseGraph::addKeyframe(uint64_t id, const Pose& odometry_pose) {
  return addNode(id, odometry_pose, nodes_.empty() ? kNone : nodes_.back().chain,
                 initial_map_from_odometry_);
}

std::string PoseGraph::startChain(uint64_t id, const Pose& odometry_pose,
                                  const Eigen::Isometry3d& map_from_odometry) {
  return addNode(id, odometry_pose, kNone, map_from_odometry);
}

std::string PoseGraph::addToChain(size_t chain, uint64_t id, const Pose& odometry_pose) {
  if (chain >= chains_.size()) {
    return "keyframe " + std::to_string(id) + ": chain " + std::to_string(chain) +
           " does not exist";
  }
  return addNode(id, odometry_pose, chain, Eigen::Isometry3d::Identity());
}

std::string PoseGraph::addNode(uint64_t id, const Pose& odometry_pose, size_t chain,
                               const Eigen::Isometry3d& new_chain_from_odometry) {
  if (!ids_.empty() && id <= ids_.back()) {
    return "keyframe id " + std::to_string(id) + " is not after the last one (" +
           std::to_string(ids_.back()) + ")";
  }
  const std::string problem = odometryPoseProblem(id, odometry_pose);
  if (!problem.empty()) return problem;
  const bool new_chain = chain == kNone;
  if (new_chain && !new_chain_from_odometry.matrix().allFinite()) {
    return "keyframe " + std::to_string(id) + ": its chain's placement is not finite";
  }
  const size_t index = nodes_.size();
  Node node;
  node.odometry = odometry_pose;
  node.odometry.orientation.normalize();
  if (new_chain) {
    node.chain = chains_.size();
    chains_.push_back({index, index});
  } else {
    node.chain = chain;
    node.previous = chains_[chain].last;
    chains_[chain].last = index;
    const Node& previous = nodes_[node.previous];
    node.metres_travelled =
        previous.metres_travelled + (node.odometry.position - previous.odometry.position).norm();
  }
  ids_.push_back(id);
  nodes_.push_back(node);
  // Placed by the odometry from its chain's last keyframe's estimate, the estimated drift taken
  // out; a chain's first keyframe where its caller puts it.
  setEstimate(index, new_chain ? new_chain_from_odometry * node.odometry.toIsometry()
                               : estimate(node.previous) * odometryStep(index));
  return "";
}

Eigen::Isometry3d PoseGraph::odometryStep(size_t index) const {
  Eigen::Isometry3d step = nodes_[nodes_[index].previous].odometry.toIsometry().inverse() *
                           nodes_[index].odometry.toIsometry();
  step.linear() = headingTurn(-heading_drift_per_m_ * step.translation().norm()) * step.rotation();
  return step;
}

std::optional<size_t> PoseGraph::indexOf(uint64_t id) const {
  const auto found = std::lower_bound(ids_.begin(), ids_.end(), id);
  if (found == ids_.end() || *found != id) return std::nullopt;
  return static_cast<size_t>(found - ids_.begin());
}

Eigen::Isometry3d PoseGraph::estimate(size_t index) const {
  const Node& node = nodes_[index];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(node.position[0], node.position[1], node.position[2]));
  pose.rotate(Eigen::Quaterniond(node.orientation[3], node.orientation[0], node.orientation[1],
                                 node.orientation[2])
                  .normalized());
  return pose;
}

Eigen::Matrix<double, 6, 1> PoseGraph::odometrySd(size_t from, size_t to) const {
  const Eigen::Isometry3d motion =
      nodes_[from].odometry.toIsometry().inverse() * nodes_[to].odometry.toIsometry();
  const double metres = motion.translation().norm();
  const double radians = rotationAngle(motion.rotation());
  Eigen::Matrix<double, 6, 1> sd;
  sd.head<3>().setConstant(options_.odometry_translation_sd_m +
                           options_.odometry_translation_sd_per_m * metres);
  sd.tail<3>().setConstant(options_.odometry_rotation_sd_rad +
                           options_.odometry_rotation_sd_per_m * metres +
                           options_.odometry_rotation_sd_per_rad * radians);
  return sd;
}

std::optional<PoseGraph::LoopCheck> PoseGraph::check(const LoopConstraint& loop,
                                                     std::optional<size_t> excluded) const {
  const std::optional<size_t> query = indexOf(loop.query_id);
  const std::optional<size_t> match = indexOf(loop.match_id);
  if (!query || !match) return std::nullopt;
  const Eigen::Vector2d path = pathVariance(*match, *query, excluded);
  if (!std::isfinite(path.x())) {
    // Two chains no loop joins yet: their estimates say nothing about each other. The loops
    // that agree with it (loop_confirmations) screen it; it then places the later chain.
    LoopCheck joining;
    joining.detail = "joins chain " + std::to_string(chainAt(*query)) + " to chain " +
                     std::to_string(chainAt(*match)) +
                     ", which no accepted loop joins yet: screened by the loops that agree "
                     "with it";
    return joining;
  }
  const Eigen::Isometry3d estimated = estimate(*query).inverse() * estimate(*match);
  const double translation_error =
      (estimated.translation() - loop.query_T_match.translation()).norm();
  const double rotation_error =
      rotationAngle(estimated.rotation() * loop.query_T_match.rotation().transpose());
  const double loop_translation_variance = loop.translationVariance();
  const double loop_rotation_variance = loop.rotationVariance();
  LoopCheck result;
  result.error_sd = std::max(translation_error / std::sqrt(path.x() + loop_translation_variance),
                             rotation_error / std::sqrt(path.y() + loop_rotation_variance));
  std::ostringstream detail;
  detail.precision(2);
  detail << std::fixed << translation_error << " m and " << rotation_error * 180.0 / M_PI
         << " deg from the graph, " << result.error_sd << " sd (translation sd "
         << std::sqrt(path.x() + loop_translation_variance) << " m)";
  result.detail = detail.str();
  return result;
}

LoopVerdict PoseGraph::addLoop(const LoopConstraint& given) {
  LoopVerdict verdict;
  const bool pose_usable = given.query_T_match.translation().allFinite() &&
                           isRotation(given.query_T_match.linear(), kRotationTolerance);
  LoopConstraint loop = given;
  // Within the tolerance, made an exact rotation: Isometry3d's inverse takes it for one.
  if (pose_usable) loop.query_T_match.linear() = given.query_T_match.rotation();
  const std::optional<Eigen::Matrix<double, 6, 6>> sqrt_information =
      sqrtInformation(loop.covariance);
  const std::optional<LoopCheck> checked =
      pose_usable ? check(loop, std::nullopt) : std::optional<LoopCheck>{};
  if (!indexOf(loop.query_id) || !indexOf(loop.match_id)) {
    verdict.decision = LoopDecision::kUnknownKeyframe;
    verdict.detail = "keyframe " +
                     std::to_string(indexOf(loop.query_id) ? loop.match_id : loop.query_id) +
                     " is not in the graph";
  } else if (!pose_usable) {
    verdict.decision = LoopDecision::kBadPose;
    verdict.detail =
        "relative pose not finite or its rotation not a rotation (a quaternion not of unit "
        "length?)";
  } else if (!sqrt_information) {
    verdict.decision = LoopDecision::kBadCovariance;
    verdict.detail = "covariance not finite or not symmetric positive definite";
  } else {
    verdict.error_sd = checked->error_sd;
    verdict.detail = checked->detail;
    // A NaN error (an estimate or a covariance that arithmetic broke) is refused too.
    if (!(checked->error_sd <= options_.max_loop_error_sd)) {
      verdict.decision = LoopDecision::kInconsistent;
    }
  }
  LoopEdge edge;
  edge.constraint = loop;
  if (verdict.decision == LoopDecision::kAccepted) {
    edge.sqrt_information = *sqrt_information;
    if (options_.loop_confirmations > 0) verdict.decision = LoopDecision::kAwaitingConfirmation;
  }
  edge.active = verdict.decision == LoopDecision::kAccepted;
  loops_.push_back(edge);
  verdicts_.push_back(verdict);
  if (verdict.decision == LoopDecision::kAwaitingConfirmation ||
      (verdict.decision == LoopDecision::kInconsistent && options_.loop_confirmations > 0)) {
    confirm(loops_.size() - 1, &verdict);
    verdicts_.back().decision = verdict.decision;
    verdicts_.back().detail = verdict.detail;
  }
  return verdict;
}

size_t PoseGraph::activeLoops() const {
  return static_cast<size_t>(std::count_if(loops_.begin(), loops_.end(),
                                           [](const LoopEdge& edge) { return edge.active; }));
}

bool PoseGraph::solve(size_t first_free, OptimisationReport* report) {
  // Incremental where it pays: keyframes before the earliest one a new loop touches are held
  // where they are (as VINS-Fusion's loop fusion does), so a loop between the last two laps of
  // a long run moves one lap, not the whole run. Edges between held keyframes are left out.
  first_free = std::max<size_t>(first_free, 1);
  if (first_free >= nodes_.size()) return false;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion;
  ceres::CauchyLoss loop_loss(options_.loop_loss_scale);
  std::vector<bool> present(nodes_.size(), false);
  const auto add = [&](size_t a, size_t b, ceres::CostFunction* cost, ceres::LossFunction* loss) {
    problem.AddResidualBlock(cost, loss, nodes_[a].position, nodes_[a].orientation,
                             nodes_[b].position, nodes_[b].orientation);
    present[a] = present[b] = true;
  };
  const bool estimate_drift = options_.heading_drift_prior_sd_per_m > 0.0;
  for (size_t j = first_free; j < nodes_.size(); ++j) {
    const size_t i = nodes_[j].previous;
    if (i == kNone) continue;  // A chain's first keyframe.
    const Eigen::Isometry3d motion =
        nodes_[i].odometry.toIsometry().inverse() * nodes_[j].odometry.toIsometry();
    const Eigen::Matrix<double, 6, 1> sd = odometrySd(i, j);
    const Eigen::Matrix<double, 6, 6> sqrt_information = sd.cwiseInverse().asDiagonal();
    if (estimate_drift) {
      problem.AddResidualBlock(DriftingOdometryResidual::create(motion, sqrt_information), nullptr,
                               nodes_[i].position, nodes_[i].orientation, nodes_[j].position,
                               nodes_[j].orientation, &heading_drift_per_m_);
      present[i] = present[j] = true;
    } else {
      add(i, j, RelativePoseResidual::create(motion, sqrt_information), nullptr);
    }
  }
  if (estimate_drift) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<DriftPrior, 1, 1>(
                                 new DriftPrior{options_.heading_drift_prior_sd_per_m}),
                             nullptr, &heading_drift_per_m_);
  }
  size_t active = 0;
  for (LoopEdge& edge : loops_) {
    if (!edge.active) continue;
    const size_t query = *indexOf(edge.constraint.query_id);
    const size_t match = *indexOf(edge.constraint.match_id);
    if (query == match || std::max(query, match) < first_free) continue;
    add(query, match,
        RelativePoseResidual::create(edge.constraint.query_T_match, edge.sqrt_information),
        &loop_loss);
    ++active;
  }
  if (active == 0 || nodes_.size() < 2) return false;
  // A group of chains no loop joins to the held keyframes floats: its first keyframe is held.
  // Chains come in keyframe order, so every keyframe of such a group is free.
  std::vector<bool> held(nodes_.size(), false);
  for (size_t i = 0; i < std::min(first_free, nodes_.size()); ++i) held[i] = true;
  const std::vector<size_t> group = chainGroups(false);
  for (size_t c = 0; c < group.size(); ++c) {
    if (group[c] == c) held[chains_[c].first] = true;
  }
  for (size_t i = 0; i < nodes_.size(); ++i) {
    if (!present[i]) continue;
    problem.SetManifold(nodes_[i].orientation, &quaternion);
    if (held[i]) {
      problem.SetParameterBlockConstant(nodes_[i].position);
      problem.SetParameterBlockConstant(nodes_[i].orientation);
    }
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  report->ran = true;
  if (!summary.IsSolutionUsable()) return false;
  for (LoopEdge& edge : loops_) edge.optimised = edge.active;
  return true;
}

OptimisationReport PoseGraph::optimise() {
  OptimisationReport report;
  const auto start = Clock::now();
  constexpr int kRounds = 3;
  // The earliest keyframe a loop the estimate has not seen yet touches, or that a loop joining
  // two chains moved.
  size_t first_free = placeJoinedChains();
  for (const LoopEdge& edge : loops_) {
    if (!edge.active || edge.optimised) continue;
    first_free = std::min(
        {first_free, *indexOf(edge.constraint.query_id), *indexOf(edge.constraint.match_id)});
  }
  for (int round = 0; round < kRounds; ++round) {
    if (!solve(first_free, &report)) break;
    // The loops the optimised graph agrees with least (in their own covariance's terms), each
    // checked against the uncertainty of the graph without it: the worst one that fails is
    // switched off, one per round. Only a few are checked: each check walks the graph.
    std::vector<std::pair<double, size_t>> suspects;
    for (size_t k = 0; k < loops_.size(); ++k) {
      if (!loops_[k].active) continue;
      const LoopConstraint& loop = loops_[k].constraint;
      const Eigen::Isometry3d estimated =
          estimate(*indexOf(loop.query_id)).inverse() * estimate(*indexOf(loop.match_id));
      const double own_sd = std::sqrt(loop.translationVariance());
      const double own_error =
          (estimated.translation() - loop.query_T_match.translation()).norm() / own_sd;
      if (own_error > options_.max_loop_error_sd) suspects.push_back({own_error, k});
    }
    constexpr size_t kChecksPerRound = 3;
    const size_t checks = std::min(kChecksPerRound, suspects.size());
    std::partial_sort(suspects.begin(), suspects.begin() + static_cast<std::ptrdiff_t>(checks),
                      suspects.end(), std::greater<>());
    std::optional<size_t> worst;
    double worst_error = options_.max_loop_error_sd;
    for (size_t s = 0; s < checks; ++s) {
      const std::optional<LoopCheck> checked =
          check(loops_[suspects[s].second].constraint, suspects[s].second);
      if (checked && checked->error_sd > worst_error) {
        worst_error = checked->error_sd;
        worst = suspects[s].second;
      }
    }
    if (!worst) break;
    loops_[*worst].active = false;
    const LoopConstraint& off = loops_[*worst].constraint;
    first_free = std::min({first_free, *indexOf(off.query_id), *indexOf(off.match_id)});
    verdicts_[*worst].decision = LoopDecision::kSwitchedOff;
    verdicts_[*worst].error_sd = worst_error;
    report.switched_off.push_back(*worst);
  }
  if (report.ran && options_.heading_drift_prior_sd_per_m > 0.0) replaceUnloopedStart();
  report.milliseconds = millisecondsSince(start);
  return report;
}

void PoseGraph::replaceUnloopedStart() {
  // Keyframes before the earliest one a loop touches are tied to the rest by odometry alone and
  // are never freed by the incremental solve; held, they keep the drift of the start in their
  // headings, and everything after them turns with it. With the drift estimated, they are placed
  // again from the first keyframe, and the rest moves rigidly with the last of them, which leaves
  // every residual after it as it was. The first chain's start only: another chain's first
  // keyframe is placed by its loops.
  size_t earliest = kNone;
  for (const LoopEdge& edge : loops_) {
    if (!edge.active) continue;
    for (const uint64_t end : {edge.constraint.query_id, edge.constraint.match_id}) {
      const size_t index = *indexOf(end);
      if (nodes_[index].chain == 0) earliest = std::min(earliest, index);
    }
  }
  if (earliest == kNone || nodes_[earliest].previous == kNone) return;
  // The first chain before `earliest`, in order.
  std::vector<size_t> start;
  for (size_t i = nodes_[earliest].previous; i != kNone; i = nodes_[i].previous) {
    start.push_back(i);
  }
  std::reverse(start.begin(), start.end());
  if (start.size() < 2) return;
  const Eigen::Isometry3d before = estimate(start.back());
  for (size_t k = 1; k < start.size(); ++k) {
    setEstimate(start[k], estimate(start[k - 1]) * odometryStep(start[k]));
  }
  const Eigen::Isometry3d correction = estimate(start.back()) * before.inverse();
  // Everything joined to the first chain moves with it; chains still floating stay.
  const std::vector<size_t> group = chainGroups(false);
  for (size_t i = earliest; i < nodes_.size(); ++i) {
    if (group[nodes_[i].chain] == 0) setEstimate(i, correction * estimate(i));
  }
}

void PoseGraph::setEstimate(size_t index, const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond orientation = Eigen::Quaterniond(pose.rotation()).normalized();
  for (int k = 0; k < 3; ++k) nodes_[index].position[k] = pose.translation()[k];
  for (int k = 0; k < 4; ++k) nodes_[index].orientation[k] = orientation.coeffs()[k];
}

std::optional<Pose> PoseGraph::odometryPose(uint64_t id) const {
  const std::optional<size_t> index = indexOf(id);
  if (!index) return std::nullopt;
  return nodes_[*index].odometry;
}

std::optional<Pose> PoseGraph::optimisedPose(uint64_t id) const {
  const std::optional<size_t> index = indexOf(id);
  if (!index) return std::nullopt;
  return Pose::fromIsometry(estimate(*index));
}

Eigen::Isometry3d PoseGraph::mapFromOdometry() const {
  if (nodes_.empty()) return initial_map_from_odometry_;
  return estimate(nodes_.size() - 1) * nodes_.back().odometry.toIsometry().inverse();
}

}  // namespace landmark_loop_closure
