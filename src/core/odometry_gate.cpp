#include "landmark_loop_closure/core/odometry_gate.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace landmark_loop_closure {

std::string OdometryGateOptions::validate() const {
  std::ostringstream errors;
  const auto non_negative = [&errors](const char* name, double value) {
    if (!(value >= 0.0 && std::isfinite(value))) {
      errors << "odometry_gate/" << name << " must be >= 0 (got " << value << ")\n";
    }
  };
  non_negative("drift_per_metre", drift_per_metre);
  non_negative("drift_per_radian", drift_per_radian);
  non_negative("drift_floor_m", drift_floor_m);
  non_negative("max_view_distance_m", max_view_distance_m);
  return errors.str();
}

std::string OdometryGateDecision::reason() const {
  if (consistent) return "";
  std::ostringstream text;
  text.precision(1);
  text << std::fixed << "odometry: needs a " << implied_correction_m
       << " m correction, drift allows " << allowed_drift_m << " m";
  return text.str();
}

OdometryGateDecision checkOdometry(const OdometryGateOptions& options, const Pose& query_pose,
                                   const PathLength& query_path, const Pose& match_pose,
                                   const PathLength& match_path) {
  OdometryGateDecision decision;
  const double apart = (query_pose.position - match_pose.position).norm();
  decision.implied_correction_m = std::max(0.0, apart - options.max_view_distance_m);
  decision.allowed_drift_m =
      options.drift_floor_m +
      options.drift_per_metre * std::abs(query_path.metres - match_path.metres) +
      options.drift_per_radian * std::abs(query_path.radians - match_path.radians);
  decision.consistent =
      !options.enabled || decision.implied_correction_m <= decision.allowed_drift_m;
  return decision;
}

}  // namespace landmark_loop_closure
