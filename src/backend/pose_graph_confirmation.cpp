// Pairwise consistency between loops (the test of PCM, Mangelson et al. 2018, on small groups):
// two loops whose ends lie close along the odometry close a cycle with the odometry between
// their queries and between their matches; true loops close it, a wrong one seldom does.
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "landmark_loop_closure/backend/pose_graph.h"

namespace landmark_loop_closure {

PoseGraph::OdometryLeg PoseGraph::odometryLeg(size_t from, size_t to) const {
  // Along the chain (both ends in one chain), walked back from the later end.
  OdometryLeg leg;
  const size_t first = std::min(from, to);
  for (size_t i = std::max(from, to); i != first && i != kNone; i = nodes_[i].previous) {
    const Eigen::Isometry3d step = odometryStep(i);
    const Eigen::Matrix<double, 6, 1> sd = odometrySd(nodes_[i].previous, i);
    leg.motion = step * leg.motion;
    leg.translation_variance += sd[0] * sd[0];
    leg.rotation_variance += sd[3] * sd[3];
    leg.metres += step.translation().norm();
  }
  if (from > to) leg.motion = leg.motion.inverse();
  return leg;
}

double PoseGraph::pairError(const LoopConstraint& a, const LoopConstraint& b) const {
  const size_t query_a = *indexOf(a.query_id);
  const size_t match_a = *indexOf(a.match_id);
  const size_t query_b = *indexOf(b.query_id);
  const size_t match_b = *indexOf(b.match_id);
  // The cycle needs the odometry between the two queries and between the two matches.
  if (chainAt(query_a) != chainAt(query_b) || chainAt(match_a) != chainAt(match_b)) {
    return std::numeric_limits<double>::infinity();
  }
  const OdometryLeg queries = odometryLeg(query_a, query_b);
  const OdometryLeg matches = odometryLeg(match_b, match_a);
  // query_a -> match_a -> match_b -> query_b -> query_a is the identity when both loops are true.
  const Eigen::Isometry3d cycle =
      a.query_T_match.inverse() * queries.motion * b.query_T_match * matches.motion;
  const double length = a.query_T_match.translation().norm() +
                        b.query_T_match.translation().norm() + queries.metres + matches.metres;
  const double odometry_rotation = queries.rotation_variance + matches.rotation_variance;
  const double loop_rotation = a.rotationVariance() + b.rotationVariance();
  // A loop's rotation error turns the whole rest of the cycle; the odometry's is spread along it.
  const double translation_variance = a.translationVariance() + b.translationVariance() +
                                      queries.translation_variance + matches.translation_variance +
                                      loop_rotation * length * length +
                                      odometry_rotation * length * length / 3.0;
  const double rotation_variance = odometry_rotation + loop_rotation;
  return std::max(cycle.translation().norm() / std::sqrt(translation_variance),
                  Eigen::AngleAxisd(cycle.rotation()).angle() / std::sqrt(rotation_variance));
}

void PoseGraph::confirm(size_t index, LoopVerdict* verdict) {
  const LoopConstraint& own = loops_[index].constraint;
  const double own_query = nodes_[*indexOf(own.query_id)].metres_travelled;
  const double own_match = nodes_[*indexOf(own.match_id)].metres_travelled;
  const auto admit = [this](size_t k, size_t by) {
    loops_[k].active = true;
    verdicts_[k].decision = LoopDecision::kAccepted;
    verdicts_[k].detail += "; confirmed by loop " + std::to_string(by);
  };
  std::optional<size_t> first_partner;
  for (size_t k = 0; k < index; ++k) {
    // A loop the screening refused still counts as a partner: what refused it is the long
    // odometry path between its ends, which the pair test does not use.
    const LoopDecision decision = verdicts_[k].decision;
    if (decision != LoopDecision::kAccepted && decision != LoopDecision::kAwaitingConfirmation &&
        decision != LoopDecision::kInconsistent) {
      continue;
    }
    const LoopConstraint& other = loops_[k].constraint;
    // The same query seen twice is not a second observation.
    if (other.query_id == own.query_id) continue;
    const double other_query = nodes_[*indexOf(other.query_id)].metres_travelled;
    const double other_match = nodes_[*indexOf(other.match_id)].metres_travelled;
    if (std::abs(other_query - own_query) > options_.confirmation_distance_m ||
        std::abs(other_match - own_match) > options_.confirmation_distance_m) {
      continue;
    }
    if (pairError(own, other) > options_.max_loop_error_sd) continue;
    ++loops_[index].agreements;
    ++loops_[k].agreements;
    if (!first_partner) first_partner = k;
    if (decision == LoopDecision::kAwaitingConfirmation &&
        loops_[k].agreements >= options_.loop_confirmations) {
      admit(k, index);
      verdict->confirmed.push_back(k);
    }
  }
  if (verdicts_[index].decision == LoopDecision::kInconsistent) return;
  if (loops_[index].agreements >= options_.loop_confirmations) {
    admit(index, *first_partner);
    verdict->decision = LoopDecision::kAccepted;
    verdict->detail = verdicts_[index].detail;
    return;
  }
  std::ostringstream detail;
  detail << "awaiting " << options_.loop_confirmations - loops_[index].agreements
         << " more loop(s) within " << options_.confirmation_distance_m
         << " m that agree with it; screened: " << verdict->detail;
  verdict->detail = detail.str();
}

}  // namespace landmark_loop_closure
