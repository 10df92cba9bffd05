#include "landmark_loop_closure/runtime/input_monitor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace landmark_loop_closure {

InputMonitor::InputMonitor(const InputMonitorOptions& options, double now)
    : options_(options), last_paired_(now), rate_since_(now) {}

void InputMonitor::imageArrived(double now, double stamp) {
  MutexLock lock(mutex_);
  ++images_;
  last_image_ = now;
  newest_image_stamp_ = stamp;
}

void InputMonitor::poseArrived(double now, double stamp) {
  MutexLock lock(mutex_);
  ++poses_;
  last_pose_ = now;
  newest_pose_stamp_ = stamp;
}

void InputMonitor::paired(double now) {
  MutexLock lock(mutex_);
  last_paired_ = now;
}

bool InputMonitor::rejected(InputErrorCode code, double now, uint64_t* count) {
  MutexLock lock(mutex_);
  *count = ++rejected_[code];
  const auto last = last_rejection_log_.find(code);
  if (last != last_rejection_log_.end() && now - last->second < options_.rejection_log_period_s) {
    return false;
  }
  last_rejection_log_[code] = now;
  return true;
}

bool InputMonitor::imageSilent(double now) const {
  MutexLock lock(mutex_);
  return now - last_image_ > options_.timeout_s;
}

bool InputMonitor::poseSilent(double now) const {
  MutexLock lock(mutex_);
  return now - last_pose_ > options_.timeout_s;
}

std::string InputMonitor::unpaired(double now) const {
  MutexLock lock(mutex_);
  const double timeout = options_.timeout_s;
  const bool both_arrive = now - last_image_ <= timeout && now - last_pose_ <= timeout;
  if (!both_arrive || now - last_paired_ <= timeout) return "";
  char text[400];
  std::snprintf(
      text, sizeof(text),
      "Images and odometry arrive but none paired for %.0f s: newest image stamp %.3f, "
      "newest odometry stamp %.3f (%.3f s apart); an image needs odometry around its "
      "stamp (messages at most advanced/odometry_max_interval %.3f s apart), so frames are "
      "dropped until their stamps agree",
      timeout, newest_image_stamp_, newest_pose_stamp_,
      std::abs(newest_image_stamp_ - newest_pose_stamp_), options_.max_interval_s);
  return text;
}

InputMonitor::Rates InputMonitor::takeRates(double now) {
  MutexLock lock(mutex_);
  const double elapsed = std::max(1e-3, now - rate_since_);
  Rates rates;
  rates.image_hz = static_cast<double>(images_ - images_at_rate_) / elapsed;
  rates.pose_hz = static_cast<double>(poses_ - poses_at_rate_) / elapsed;
  images_at_rate_ = images_;
  poses_at_rate_ = poses_;
  rate_since_ = now;
  return rates;
}

uint64_t InputMonitor::images() const {
  MutexLock lock(mutex_);
  return images_;
}

uint64_t InputMonitor::poses() const {
  MutexLock lock(mutex_);
  return poses_;
}

std::map<InputErrorCode, uint64_t> InputMonitor::rejections() const {
  MutexLock lock(mutex_);
  return rejected_;
}

}  // namespace landmark_loop_closure
