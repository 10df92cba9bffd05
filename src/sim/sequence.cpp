#include "landmark_loop_closure/sim/sequence.h"

#include <algorithm>
#include <cmath>

namespace landmark_loop_closure {
namespace sim {

namespace {

constexpr double kLateralRampMetres = 4.0;  // The sideways shift is eased in, not a jump.

double wrapAngle(double angle) { return std::atan2(std::sin(angle), std::cos(angle)); }

}  // namespace

SequenceGenerator::SequenceGenerator(const CorridorWorld& world, const CameraModel& camera,
                                     const SequenceOptions& options)
    : world_(world), camera_(camera), options_(options) {
  const double duration = options.laps * world.lapLength() / options.speed;
  frame_count_ = static_cast<size_t>(std::floor(duration * options.rate)) + 1;
}

Pose2D SequenceGenerator::truthAt(size_t index, int* lap) const {
  const double s = index * options_.speed / options_.rate;
  *lap = static_cast<int>(std::floor(s / world_.lapLength()));
  double lateral = 0.0;
  if (*lap >= 1) {
    const double into_lap = s - world_.lapLength();
    lateral = options_.revisit_lateral * std::min(1.0, into_lap / kLateralRampMetres);
  }
  Pose2D pose = world_.poseAt(s, lateral);
  // A little head sway, as a handheld camera or a rolling robot has.
  pose.yaw = wrapAngle(pose.yaw + 0.03 * std::sin(2.0 * M_PI * s / 3.7));
  return pose;
}

bool SequenceGenerator::next(SequenceFrame* frame, bool render) {
  if (next_index_ >= frame_count_) return false;
  const size_t index = next_index_++;
  int lap = 0;
  const Pose2D truth = truthAt(index, &lap);
  if (index == 0) {
    odom_ = truth;
  } else {
    // Apply the true motion, expressed in the previous body frame, with scale and heading error.
    const double dx = truth.x - previous_truth_.x;
    const double dy = truth.y - previous_truth_.y;
    const double c = std::cos(previous_truth_.yaw);
    const double s = std::sin(previous_truth_.yaw);
    const double forward = (c * dx + s * dy) * (1.0 + options_.odom_scale_error);
    const double sideways = (-s * dx + c * dy) * (1.0 + options_.odom_scale_error);
    const double turn = wrapAngle(truth.yaw - previous_truth_.yaw) +
                        options_.odom_yaw_drift_per_metre * std::hypot(dx, dy);
    const double oc = std::cos(odom_.yaw);
    const double os = std::sin(odom_.yaw);
    odom_.x += oc * forward - os * sideways;
    odom_.y += os * forward + oc * sideways;
    odom_.yaw = wrapAngle(odom_.yaw + turn);
  }
  previous_truth_ = truth;

  frame->index = index;
  frame->stamp = options_.start_stamp + index / options_.rate;
  frame->lap = lap;
  frame->truth = truth;
  frame->odom = odom_;
  frame->image = render ? this->render(*frame) : cv::Mat();
  return true;
}

cv::Mat SequenceGenerator::render(const SequenceFrame& frame) const {
  return world_.render(frame.truth, camera_,
                       frame.lap == 0 ? options_.first_lap_lighting : options_.revisit_lighting,
                       options_.seed * 1000003u + static_cast<uint32_t>(frame.index));
}

SampledSequence sampleSequence(const CorridorWorld& world, const SequenceOptions& options,
                               size_t every) {
  SequenceGenerator sequence(world, CameraModel{}, options);
  SampledSequence sampled;
  SequenceFrame frame;
  while (sequence.next(&frame, false)) {
    if (frame.index % every != 0) continue;
    sampled.images.push_back(sequence.render(frame));
    sampled.truth.push_back(planarPose(frame.truth.x, frame.truth.y, frame.truth.yaw));
    sampled.stamps.push_back(frame.stamp);
  }
  return sampled;
}

}  // namespace sim
}  // namespace landmark_loop_closure
