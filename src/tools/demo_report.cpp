// Prints every loop closure the detector publishes as TRUE or FALSE against ground truth, the
// error of its metric relative pose, and a summary at shutdown. Ground truth: nav_msgs/Odometry
// on `ground_truth`; a loop is true by eval::TrueLoopRule: the true positions at its two stamps
// within true_loop_distance metres, the stamps revisit_min_seconds apart. With the pose_graph
// node running, the summary adds the keyframe positions' RMSE against ground truth, for the
// odometry and for the corrected path, each aligned on its first keyframe.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <Eigen/Geometry>

#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/geometry/pose.h"

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/PoseGraphLoop.h"

namespace {

class DemoReport {
 public:
  explicit DemoReport(ros::NodeHandle& node, ros::NodeHandle& private_node) {
    private_node.param("true_loop_distance", rule_.max_distance_m, rule_.max_distance_m);
    private_node.param("revisit_min_seconds", rule_.min_gap_s, rule_.min_gap_s);
    // The detector's camera mount turns true body poses into true camera poses.
    std::string detector;
    private_node.param<std::string>("detector", detector, "loop_closure");
    landmark_loop_closure::CameraMount mount;
    for (auto& [key, value] : {std::pair<const char*, double*>{"x", &mount.x},
                               {"y", &mount.y},
                               {"z", &mount.z},
                               {"roll", &mount.roll},
                               {"pitch", &mount.pitch},
                               {"yaw", &mount.yaw}}) {
      node.param(detector + "/camera_mount/" + key, *value, *value);
    }
    camera_in_base_ = mount.toPose().toIsometry();
    truth_subscriber_ = node.subscribe("ground_truth", 1000, &DemoReport::onTruth, this);
    loop_subscriber_ = node.subscribe("loop_closures", 100, &DemoReport::onLoop, this);
    keyframe_subscriber_ = node.subscribe("keyframes", 1000, &DemoReport::onKeyframe, this);
    corrected_subscriber_ =
        node.subscribe("pose_graph/corrected_path", 2, &DemoReport::onCorrectedPath, this);
    verdict_subscriber_ =
        node.subscribe("pose_graph/loop_verdicts", 1000, &DemoReport::onVerdict, this);
  }

  /// Judges what still waits for truth with the truth there is (the bag has ended).
  void finish() { judgeWaiting(true); }

  void printSummary() const {
    const int false_loops = loops_ - true_loops_;
    std::printf("\n==== demo summary ====\n");
    std::printf("keyframes:            %d\n", keyframes_);
    std::printf("revisited keyframes:  %d (a keyframe >= %.0f s older lies within %.1f m)\n",
                revisited_keyframes_, rule_.min_gap_s, rule_.max_distance_m);
    std::printf("loops published:      %d (true %d, false %d)\n", loops_, true_loops_, false_loops);
    if (loops_ > 0) {
      std::printf("precision:            %.3f\n", static_cast<double>(true_loops_) / loops_);
    }
    if (revisited_keyframes_ > 0) {
      std::printf("recall (keyframes):   %.3f\n",
                  static_cast<double>(true_loops_) / revisited_keyframes_);
    }
    std::printf("verified:             %d, of which %zu with a metric relative pose\n", verified_,
                translation_errors_.size());
    std::printf("by appearance:        %d (ORB could not confirm them; no relative pose)\n",
                appearance_verified_);
    if (!translation_errors_.empty()) {
      std::printf("metric pose error:    median %.3f m %.2f deg, 90th percentile %.3f m %.2f deg\n",
                  percentile(translation_errors_, 0.5), percentile(rotation_errors_, 0.5),
                  percentile(translation_errors_, 0.9), percentile(rotation_errors_, 0.9));
    }
    printTrajectoryError();
    printGraphVerdicts();
    std::fflush(stdout);
  }

 private:
  static double percentile(std::vector<double> values, double fraction) {
    const auto rank = static_cast<size_t>(fraction * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank),
                     values.end());
    return values[rank];
  }

  static Eigen::Vector3d toVector(const geometry_msgs::Point& point) {
    return {point.x, point.y, point.z};
  }

  static Eigen::Isometry3d toIsometry(const geometry_msgs::Pose& pose) {
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    transform.linear() = Eigen::Quaterniond(pose.orientation.w, pose.orientation.x,
                                            pose.orientation.y, pose.orientation.z)
                             .normalized()
                             .toRotationMatrix();
    transform.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
    return transform;
  }

  bool truthAt(const ros::Time& stamp, geometry_msgs::Pose* pose) const {
    if (truth_.empty()) return false;
    auto it = truth_.lower_bound(stamp);
    if (it == truth_.end()) it = std::prev(it);
    if (it != truth_.begin()) {
      const auto before = std::prev(it);
      if ((stamp - before->first) < (it->first - stamp)) it = before;
    }
    if (std::abs((it->first - stamp).toSec()) > kTruthTolerance) return false;
    *pose = it->second;
    return true;
  }

  void onCorrectedPath(const nav_msgs::PathConstPtr& path) { corrected_path_ = path; }

  /// The pose graph's decisions, judged by ground truth: a decision is final once given, except
  /// that an accepted loop may be switched off later (the last word counts).
  void onVerdict(const landmark_loop_closure::PoseGraphLoopConstPtr& verdict) {
    if (verdict->decision == "left_out") return;
    geometry_msgs::Pose query;
    geometry_msgs::Pose match;
    if (!truthAt(verdict->query_stamp, &query) || !truthAt(verdict->match_stamp, &match)) return;
    const bool is_true = rule_.isTrueLoop(toVector(query.position), verdict->query_stamp.toSec(),
                                          toVector(match.position), verdict->match_stamp.toSec());
    graph_verdicts_[{verdict->query_id, verdict->match_id}] = {is_true,
                                                               verdict->decision == "accepted"};
  }

  void printGraphVerdicts() const {
    if (graph_verdicts_.empty()) return;
    int wrong = 0, wrong_refused = 0, right = 0, right_refused = 0;
    for (const auto& [ids, verdict] : graph_verdicts_) {
      const auto [is_true, accepted] = verdict;
      (is_true ? right : wrong) += 1;
      if (!accepted) (is_true ? right_refused : wrong_refused) += 1;
    }
    std::printf("pose graph loops:     %d true (%d refused), %d false (%d refused)\n", right,
                right_refused, wrong, wrong_refused);
  }

  /// The path's keyframes against ground truth at their stamps (those without truth skipped).
  landmark_loop_closure::eval::TrajectoryError trajectoryError(
      const std::vector<std::pair<ros::Time, geometry_msgs::Pose>>& path) const {
    std::vector<landmark_loop_closure::Pose> estimated;
    std::vector<landmark_loop_closure::Pose> true_poses;
    for (const auto& [stamp, pose] : path) {
      geometry_msgs::Pose truth;
      if (!truthAt(stamp, &truth)) continue;
      estimated.push_back(landmark_loop_closure::Pose::fromIsometry(toIsometry(pose)));
      true_poses.push_back(landmark_loop_closure::Pose::fromIsometry(toIsometry(truth)));
    }
    return landmark_loop_closure::eval::trajectoryError(estimated, true_poses);
  }

  void printTrajectoryError() const {
    if (!corrected_path_) {
      std::printf("trajectory RMSE:      no corrected path (is the pose_graph node running?)\n");
      return;
    }
    std::vector<std::pair<ros::Time, geometry_msgs::Pose>> corrected;
    for (const auto& pose : corrected_path_->poses) {
      corrected.emplace_back(pose.header.stamp, pose.pose);
    }
    const auto odometry = trajectoryError(keyframe_odometry_);
    const auto optimised = trajectoryError(corrected);
    std::printf(
        "trajectory RMSE:      odometry %.3f m, corrected by the pose graph %.3f m "
        "(%zu keyframes, first pose aligned); best similarity fit: %.3f m and %.3f m "
        "(scale %.3f and %.3f)\n",
        odometry.first_pose_rmse, optimised.first_pose_rmse, corrected.size(),
        odometry.similarity_rmse, optimised.similarity_rmse, odometry.scale, optimised.scale);
  }

  // Keyframes and loops wait until the truth at their stamps has come: the bag player sends it on
  // a connection of its own, and on a busy machine a loop (from the detector, after the image)
  // can arrive before it. Judged in the order they came.
  void onTruth(const nav_msgs::OdometryConstPtr& truth) {
    truth_[truth->header.stamp] = truth->pose.pose;
    judgeWaiting(false);
  }

  void onKeyframe(const landmark_loop_closure::KeyframeConstPtr& keyframe) {
    waiting_keyframes_.push_back(keyframe);
    judgeWaiting(false);
  }

  void onLoop(const landmark_loop_closure::LoopClosureConstPtr& loop) {
    waiting_loops_.push_back(loop);
    judgeWaiting(false);
  }

  // Truth past stamp + the tolerance has come, so the nearest truth is here (the bag sends it in
  // stamp order).
  bool truthCovers(const ros::Time& stamp) const {
    return !truth_.empty() && (truth_.rbegin()->first - stamp).toSec() >= kTruthTolerance;
  }

  void judgeWaiting(bool all) {
    while (!waiting_keyframes_.empty() &&
           (all || truthCovers(waiting_keyframes_.front()->header.stamp))) {
      judgeKeyframe(*waiting_keyframes_.front());
      waiting_keyframes_.pop_front();
    }
    while (!waiting_loops_.empty() && (all || truthCovers(waiting_loops_.front()->query_stamp))) {
      judgeLoop(*waiting_loops_.front());
      waiting_loops_.pop_front();
    }
  }

  void judgeKeyframe(const landmark_loop_closure::Keyframe& keyframe_message) {
    const landmark_loop_closure::Keyframe* keyframe = &keyframe_message;
    ++keyframes_;
    keyframe_odometry_.emplace_back(keyframe->header.stamp, keyframe->pose);
    geometry_msgs::Pose here_pose;
    if (!truthAt(keyframe->header.stamp, &here_pose)) return;
    const geometry_msgs::Point& here = here_pose.position;
    for (const auto& [stamp, position] : keyframe_truth_) {
      if ((keyframe->header.stamp - stamp).toSec() < rule_.min_gap_s) break;
      if (rule_.isTrueLoop(toVector(here), keyframe->header.stamp.toSec(), toVector(position),
                           stamp.toSec())) {
        ++revisited_keyframes_;
        break;
      }
    }
    keyframe_truth_[keyframe->header.stamp] = here;
  }

  void judgeLoop(const landmark_loop_closure::LoopClosure& loop_message) {
    const landmark_loop_closure::LoopClosure* loop = &loop_message;
    ++loops_;
    geometry_msgs::Pose query_pose;
    geometry_msgs::Pose match_pose;
    if (!truthAt(loop->query_stamp, &query_pose) || !truthAt(loop->match_stamp, &match_pose)) {
      std::printf("loop %lu -> %lu: no ground truth at its stamps\n",
                  static_cast<unsigned long>(loop->query_id),
                  static_cast<unsigned long>(loop->match_id));
      return;
    }
    const geometry_msgs::Point& query = query_pose.position;
    const geometry_msgs::Point& match = match_pose.position;
    const double distance = (toVector(query) - toVector(match)).norm();
    const bool is_true = rule_.isTrueLoop(toVector(query), loop->query_stamp.toSec(),
                                          toVector(match), loop->match_stamp.toSec());
    true_loops_ += is_true ? 1 : 0;
    verified_ += loop->verified ? 1 : 0;
    appearance_verified_ += loop->appearance_verified ? 1 : 0;
    char pose_error[96] = "";
    if (loop->has_relative_pose && loop->relative_pose_metric) {
      // T_query_match of the true camera poses against the published one.
      const Eigen::Isometry3d truth = (toIsometry(query_pose) * camera_in_base_).inverse() *
                                      toIsometry(match_pose) * camera_in_base_;
      const Eigen::Isometry3d estimate = toIsometry(loop->relative_pose.pose);
      translation_errors_.push_back((estimate.translation() - truth.translation()).norm());
      rotation_errors_.push_back(
          Eigen::AngleAxisd(estimate.linear() * truth.linear().transpose()).angle() * 180.0 / M_PI);
      std::snprintf(pose_error, sizeof(pose_error), "  pose error %.3f m %.2f deg",
                    translation_errors_.back(), rotation_errors_.back());
    }
    std::printf("loop keyframe %4lu -> %4lu  score %.3f  true distance %5.2f m  %s%s\n",
                static_cast<unsigned long>(loop->query_id),
                static_cast<unsigned long>(loop->match_id), loop->score, distance,
                is_true ? "TRUE" : "FALSE", pose_error);
    std::fflush(stdout);
  }

  static constexpr double kTruthTolerance = 0.5;  ///< Seconds from a stamp to its truth.

  landmark_loop_closure::eval::TrueLoopRule rule_;
  std::deque<landmark_loop_closure::KeyframeConstPtr> waiting_keyframes_;
  std::deque<landmark_loop_closure::LoopClosureConstPtr> waiting_loops_;
  ros::Subscriber truth_subscriber_;
  ros::Subscriber loop_subscriber_;
  ros::Subscriber keyframe_subscriber_;
  ros::Subscriber corrected_subscriber_;
  ros::Subscriber verdict_subscriber_;
  std::map<std::pair<uint64_t, uint64_t>, std::pair<bool, bool>> graph_verdicts_;
  nav_msgs::PathConstPtr corrected_path_;
  std::vector<std::pair<ros::Time, geometry_msgs::Pose>> keyframe_odometry_;
  Eigen::Isometry3d camera_in_base_ = Eigen::Isometry3d::Identity();
  std::map<ros::Time, geometry_msgs::Pose> truth_;
  std::map<ros::Time, geometry_msgs::Point> keyframe_truth_;
  int keyframes_ = 0;
  int revisited_keyframes_ = 0;
  int loops_ = 0;
  int true_loops_ = 0;
  int verified_ = 0;
  int appearance_verified_ = 0;
  std::vector<double> translation_errors_;
  std::vector<double> rotation_errors_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "demo_report");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  DemoReport report(node, private_node);
  ros::spin();
  report.finish();
  report.printSummary();
  return 0;
}
