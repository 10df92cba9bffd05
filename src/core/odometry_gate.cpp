#include "landmark_loop_closure/core/odometry_gate.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace landmark_loop_closure {

const ParameterTable<OdometryGateOptions>& OdometryGateOptions::parameters() {
  using O = OdometryGateOptions;
  static const auto table =
      ParameterTable<O>("advanced/odometry_gate/",
                        "refuses loops the odometry cannot have drifted into (precision first).")
          .flag("enabled", &O::enabled, "")
          .number("drift_per_metre", &O::drift_per_metre, atLeast(0),
                  "metres of position error the odometry gains per metre travelled between the "
                  "two keyframes (path summed over keyframes).")
          .number("drift_per_radian", &O::drift_per_radian, atLeast(0),
                  "metres of position error gained per radian turned between them.")
          .number("drift_floor_m", &O::drift_floor_m, atLeast(0), "allowed in any case.")
          .number("max_view_distance_m", &O::max_view_distance_m, atLeast(0),
                  "cameras farther apart than this cannot see the same place, so a loop asks for "
                  "at least (odometry distance - this) of correction; refused when that exceeds "
                  "floor + drift. Shown as \"odometry_rejected\".");
  return table;
}

std::string OdometryGateOptions::validate() const { return parameters().check(*this); }

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
