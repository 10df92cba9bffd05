#include "landmark_loop_closure/sim/driven_laps.h"

#include <cmath>
#include <random>

namespace landmark_loop_closure {
namespace sim {

DrivenLaps driveLaps(const DrivenLapsOptions& options) {
  DrivenLaps drive;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d odometry = Eigen::Isometry3d::Identity();
  const double sides[4] = {options.length, options.width, options.length, options.width};
  std::mt19937 random(options.seed);
  std::normal_distribution<double> noise(0.0, options.step_noise_m);
  const auto keep = [&] {
    drive.truth.push_back(Pose::fromIsometry(truth));
    drive.odometry.push_back(Pose::fromIsometry(odometry));
  };
  keep();
  for (int lap = 0; lap < options.laps; ++lap) {
    for (const double side : sides) {
      const int steps = static_cast<int>(std::lround(side / options.step));
      for (int step = 0; step < steps; ++step) {
        Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
        motion.translate(Eigen::Vector3d(options.step, 0.0, 0.0));
        truth = truth * motion;
        motion.translation().x() += noise(random);
        odometry = odometry * motion;
        keep();
      }
      truth.rotate(Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ()));
      odometry.rotate(
          Eigen::AngleAxisd(M_PI / 2.0 * (1.0 + options.turn_error), Eigen::Vector3d::UnitZ()));
    }
    if (lap == 0) drive.keyframes_per_lap = drive.truth.size() - 1;
  }
  return drive;
}

}  // namespace sim
}  // namespace landmark_loop_closure
