#pragma once

#include <string>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// How far the odometry may have drifted between two keyframes: a loop that asks for a larger
/// correction contradicts the odometry and is refused.
struct OdometryGateOptions {
  bool enabled = true;
  double drift_per_metre = 0.1;   ///< Metres of position error gained per metre travelled.
  double drift_per_radian = 0.5;  ///< Metres of position error gained per radian turned.
  double drift_floor_m = 1.0;     ///< Allowed in any case (odometry noise, keyframe spacing).
  /// Two cameras farther apart than this do not see the same place: the least correction a loop
  /// between them implies is their odometry distance minus this.
  double max_view_distance_m = 4.0;

  /// Keys under odometry_gate/, documented in config/default.yaml.
  static const ParameterTable<OdometryGateOptions>& parameters();
  std::string validate() const;
};

struct OdometryGateDecision {
  bool consistent = true;
  double implied_correction_m = 0.0;  ///< Least position correction the loop asks for.
  double allowed_drift_m = 0.0;       ///< What the drift model allows between the two keyframes.
  std::string reason() const;         ///< Empty when consistent.
};

/// Checks a loop between two keyframes against the odometry's drift model.
OdometryGateDecision checkOdometry(const OdometryGateOptions& options, const Pose& query_pose,
                                   const PathLength& query_path, const Pose& match_pose,
                                   const PathLength& match_path);

}  // namespace landmark_loop_closure
