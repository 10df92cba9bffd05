#include "camera_info_state.h"

#include <ros/ros.h>

#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

void CameraInfoState::received(const sensor_msgs::CameraInfo& info) {
  const CameraIntrinsics intrinsics = fromCameraInfo(info, images_rectified_);
  MutexLock lock(mutex_);
  intrinsics_ = intrinsics;
  seen_ = true;
}

CameraInfoState::ForImage CameraInfoState::forImage(cv::Size image) const {
  MutexLock lock(mutex_);
  ForImage result;
  result.intrinsics = intrinsics_;
  if (seen_) {
    result.problem = intrinsics_.checkFor(image);
    if (result.problem) result.intrinsics = CameraIntrinsics();
  }
  return result;
}

void CameraInfoState::noteAccepted(const std::optional<CalibrationProblem>& problem) {
  // Unusable calibration turns the geometric check off: said once per period and cause, and in
  // the diagnostics and every loop's log line, instead of silently.
  MutexLock lock(mutex_);
  if (!seen_) return;
  problem_ = problem ? problem->text : "";
  if (problem && warnings_.allow(problem->cause, ros::WallTime::now().toSec())) {
    ROS_WARN("camera_info not used, the geometric check is off (%s): %s", problem->cause.c_str(),
             problem->text.c_str());
  }
}

CameraIntrinsics CameraInfoState::latest() const {
  MutexLock lock(mutex_);
  return intrinsics_;
}

bool CameraInfoState::seen() const {
  MutexLock lock(mutex_);
  return seen_;
}

std::string CameraInfoState::problem() const {
  MutexLock lock(mutex_);
  return problem_;
}

}  // namespace landmark_loop_closure
