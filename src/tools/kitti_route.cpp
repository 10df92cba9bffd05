#include "kitti_route.h"

#include <cmath>
#include <random>

namespace landmark_loop_closure {
namespace tools {

KittiRoute kittiRoute(const std::vector<Pose>& camera_poses, const KittiRouteOptions& options) {
  KittiRoute route;
  if (camera_poses.empty()) return route;
  // KITTI's camera frame to a body frame (x forward, y left, z up), so that heading is yaw.
  Eigen::Matrix3d body_to_camera;
  body_to_camera << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Eigen::Isometry3d camera_T_body = Eigen::Isometry3d::Identity();
  camera_T_body.linear() = body_to_camera;
  const auto body = [&](const Pose& camera) { return camera.toIsometry() * camera_T_body; };
  route.truth.push_back(Pose::fromIsometry(body(camera_poses.front())));
  for (const Pose& pose : camera_poses) {
    if ((pose.position - route.truth.back().position).norm() >= options.keyframe_step_m) {
      route.truth.push_back(Pose::fromIsometry(body(pose)));
    }
  }
  std::mt19937 random(options.seed);
  std::normal_distribution<double> normal;
  Eigen::Isometry3d odometry = route.truth.front().toIsometry();
  route.odometry.push_back(route.truth.front());
  double heading_error_per_m = options.heading_error_per_m;
  for (size_t i = 1; i < route.truth.size(); ++i) {
    Eigen::Isometry3d step =
        route.truth[i - 1].toIsometry().inverse() * route.truth[i].toIsometry();
    const double distance = step.translation().norm();
    step.translation() *= 1.0 + options.scale_error;
    for (int axis = 0; axis < 3; ++axis) {
      step.translation()[axis] += options.step_noise_m * normal(random);
    }
    if (options.heading_error_walk > 0.0) {
      heading_error_per_m += options.heading_error_walk * std::sqrt(distance) * normal(random);
    }
    const double turn = std::atan2(step.linear()(1, 0), step.linear()(0, 0));  // Yaw.
    step.linear() = Eigen::AngleAxisd(heading_error_per_m * distance + options.turn_error * turn,
                                      Eigen::Vector3d::UnitZ()) *
                    step.linear();
    odometry = odometry * step;
    route.odometry.push_back(Pose::fromIsometry(odometry));
  }
  for (size_t i = options.loop_min_gap; i < route.truth.size(); ++i) {
    size_t nearest = i;
    double nearest_distance = options.loop_radius_m;
    for (size_t j = 0; j + options.loop_min_gap <= i; ++j) {
      const double distance = (route.truth[i].position - route.truth[j].position).norm();
      if (distance < nearest_distance) {
        nearest = j;
        nearest_distance = distance;
      }
    }
    if (nearest == i) continue;
    LoopConstraint loop;
    loop.query_id = i;
    loop.match_id = nearest;
    Eigen::Isometry3d relative =
        route.truth[i].toIsometry().inverse() * route.truth[nearest].toIsometry();
    Eigen::Vector3d rotation_noise;
    for (int axis = 0; axis < 3; ++axis) {
      relative.translation()[axis] += options.loop_noise_m * normal(random);
      rotation_noise[axis] = options.loop_noise_rad * normal(random);
    }
    relative.linear() =
        Eigen::AngleAxisd(rotation_noise.norm(), rotation_noise.normalized()).toRotationMatrix() *
        relative.linear();
    loop.query_T_match = relative;
    loop.covariance.setZero();
    const double t = options.loop_noise_m * options.loop_noise_m;
    const double r = options.loop_noise_rad * options.loop_noise_rad;
    loop.covariance.diagonal() << t, t, t, r, r, r;
    route.loops.push_back(loop);
    route.wrong.push_back(false);
  }
  // Wrong loops as loop_injector makes them: another older keyframe, the published pose kept.
  std::uniform_real_distribution<double> share(0.0, 1.0);
  for (size_t k = 0; k < route.loops.size(); ++k) {
    LoopConstraint& loop = route.loops[k];
    if (share(random) >= options.wrong_fraction || loop.query_id < 2 * options.wrong_min_gap) {
      continue;
    }
    std::uniform_int_distribution<uint64_t> older(0, loop.query_id - options.wrong_min_gap);
    const auto far_enough = [&](uint64_t match) {
      return (match > loop.match_id ? match - loop.match_id : loop.match_id - match) >=
             options.wrong_min_gap;
    };
    uint64_t match = older(random);
    for (int tries = 0; tries < 100 && !far_enough(match); ++tries) match = older(random);
    if (!far_enough(match)) continue;
    loop.match_id = match;
    route.wrong[k] = true;
  }
  return route;
}

}  // namespace tools
}  // namespace landmark_loop_closure
