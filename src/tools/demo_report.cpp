// Prints every loop closure the detector publishes as TRUE or FALSE against ground truth, the
// error of its metric relative pose, and a summary at shutdown. Ground truth: nav_msgs/Odometry
// on `ground_truth`; a loop is true by eval::TrueLoopRule: the true positions at its two stamps
// within true_loop_distance metres, the stamps revisit_min_seconds apart. With the pose_graph
// node running, the summary adds the keyframe positions' RMSE against ground truth, for the
// odometry and for the corrected path, each aligned on its first keyframe.
// With the parameter `robots` ("/robot_a /robot_b"), it listens to each robot's detector (ROBOT/
// keyframes, ROBOT/loop_closures) and to the fleet's pose graph (pose_graph/ROBOT/corrected_path),
// names each loop's robots, counts the loops between robots, and measures all robots' corrected
// keyframes in the one map frame (the ground truth of every robot on one `ground_truth` topic).
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

#include "landmark_loop_closure/common/text_and_files.h"
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
    std::string robots;
    private_node.param<std::string>("robots", robots, "");
    robots_ = landmark_loop_closure::parseNameList(robots);  // As the pose graph reads its own.
    // The detector's camera mount turns true body poses into true camera poses.
    std::string detector;
    private_node.param<std::string>(
        "detector", detector, robots_.empty() ? "loop_closure" : robots_.front() + "/loop_closure");
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
    verdict_subscriber_ =
        node.subscribe("pose_graph/loop_verdicts", 1000, &DemoReport::onVerdict, this);
    if (robots_.empty()) {
      listenTo(node, "", "");
      return;
    }
    for (const std::string& robot : robots_) {
      const size_t name_start = robot.find_first_not_of('/');
      if (name_start == std::string::npos) continue;  // "/" names no robot.
      listenTo(node, robot + "/", robot.substr(name_start));
    }
  }

  /// The detector's keyframes and loops under `prefix`, and the pose graph's path of `robot`.
  void listenTo(ros::NodeHandle& node, const std::string& prefix, const std::string& robot) {
    using landmark_loop_closure::KeyframeConstPtr;
    using landmark_loop_closure::LoopClosureConstPtr;
    subscribers_.push_back(node.subscribe<landmark_loop_closure::Keyframe>(
        prefix + "keyframes", 1000, [this, robot](const KeyframeConstPtr& keyframe) {
          robot_of_map_[keyframe->map_id] = robot;
          onKeyframe({robot, keyframe});
        }));
    subscribers_.push_back(node.subscribe<landmark_loop_closure::LoopClosure>(
        prefix + "loop_closures", 100, [this](const LoopClosureConstPtr& loop) { onLoop(loop); }));
    const std::string path_topic =
        robot.empty() ? "pose_graph/corrected_path" : "pose_graph/" + robot + "/corrected_path";
    subscribers_.push_back(node.subscribe<nav_msgs::Path>(
        path_topic, 2,
        [this, robot](const nav_msgs::PathConstPtr& path) { corrected_paths_[robot] = path; }));
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
    if (!robots_.empty()) {
      std::printf("between robots:       %d (true %d, false %d)\n", loops_between_robots_,
                  true_loops_between_robots_, loops_between_robots_ - true_loops_between_robots_);
    }
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

  /// The pose graph's decisions, judged by ground truth: a decision is final once given, except
  /// that an accepted loop may be switched off later (the last word counts).
  void onVerdict(const landmark_loop_closure::PoseGraphLoopConstPtr& verdict) {
    if (verdict->decision == "left_out") return;
    geometry_msgs::Pose query;
    geometry_msgs::Pose match;
    if (!truthAt(verdict->query_stamp, &query) || !truthAt(verdict->match_stamp, &match)) return;
    const bool is_true = rule_.isTrueLoop(toVector(query.position), verdict->query_stamp.toSec(),
                                          toVector(match.position), verdict->match_stamp.toSec());
    graph_verdicts_[{verdict->query_stamp, verdict->match_stamp}] = {
        is_true, verdict->decision == "accepted"};
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
    if (corrected_paths_.empty()) {
      std::printf("trajectory RMSE:      no corrected path (is the pose_graph node running?)\n");
      return;
    }
    // Every robot's corrected keyframes lie in the one map frame: measured together.
    std::vector<std::pair<ros::Time, geometry_msgs::Pose>> corrected;
    for (const auto& [robot, path] : corrected_paths_) {
      for (const auto& pose : path->poses) corrected.emplace_back(pose.header.stamp, pose.pose);
    }
    std::sort(corrected.begin(), corrected.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    const auto optimised = trajectoryError(corrected);
    if (!robots_.empty() && posed_loops_between_robots_ == 0) {
      // Only a loop with a relative pose joins two odometry chains in the pose graph.
      std::printf(
          "trajectory RMSE:      no loop with a relative pose joined the robots: each path is in "
          "its own frame\n");
      return;
    }
    if (!robots_.empty()) {
      // Each robot's odometry has a frame of its own: only the corrected paths share one.
      std::printf(
          "trajectory RMSE:      all robots' keyframes corrected by the pose graph, in one frame: "
          "%.3f m (%zu keyframes, first pose aligned); best similarity fit: %.3f m (scale "
          "%.3f)\n",
          optimised.first_pose_rmse, corrected.size(), optimised.similarity_rmse, optimised.scale);
      return;
    }
    const auto own = keyframe_odometry_.find("");
    const auto odometry =
        trajectoryError(own == keyframe_odometry_.end() ? decltype(own->second){} : own->second);
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

  void onKeyframe(std::pair<std::string, landmark_loop_closure::KeyframeConstPtr> keyframe) {
    waiting_keyframes_.push_back(std::move(keyframe));
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
           (all || truthCovers(waiting_keyframes_.front().second->header.stamp))) {
      judgeKeyframe(waiting_keyframes_.front().first, *waiting_keyframes_.front().second);
      waiting_keyframes_.pop_front();
    }
    while (!waiting_loops_.empty() && (all || truthCovers(waiting_loops_.front()->query_stamp))) {
      judgeLoop(*waiting_loops_.front());
      waiting_loops_.pop_front();
    }
  }

  void judgeKeyframe(const std::string& robot,
                     const landmark_loop_closure::Keyframe& keyframe_message) {
    const landmark_loop_closure::Keyframe* keyframe = &keyframe_message;
    ++keyframes_;
    keyframe_odometry_[robot].emplace_back(keyframe->header.stamp, keyframe->pose);
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
    const uint64_t match_map = loop->match_map_id != 0 ? loop->match_map_id : loop->map_id;
    if (!robots_.empty() && match_map != loop->map_id) {
      ++loops_between_robots_;
      posed_loops_between_robots_ += loop->has_relative_pose ? 1 : 0;
      true_loops_between_robots_ += is_true ? 1 : 0;
    }
    std::printf("loop keyframe %s%4lu -> %s%4lu  score %.3f  true distance %5.2f m  %s%s\n",
                robotPrefix(loop->map_id).c_str(), static_cast<unsigned long>(loop->query_id),
                robotPrefix(match_map).c_str(), static_cast<unsigned long>(loop->match_id),
                loop->score, distance, is_true ? "TRUE" : "FALSE", pose_error);
    std::fflush(stdout);
  }

  /// "robot_a " for a keyframe of robot_a's map when several robots are reported, else "".
  std::string robotPrefix(uint64_t map_id) const {
    if (robots_.empty()) return "";
    const auto robot = robot_of_map_.find(map_id);
    return (robot == robot_of_map_.end() ? std::string("(unknown robot)") : robot->second) + " ";
  }

  static constexpr double kTruthTolerance = 0.5;  ///< Seconds from a stamp to its truth.

  landmark_loop_closure::eval::TrueLoopRule rule_;
  std::vector<std::string> robots_;  ///< Their namespaces; empty: one detector, no namespace.
  std::map<uint64_t, std::string> robot_of_map_;
  std::deque<std::pair<std::string, landmark_loop_closure::KeyframeConstPtr>> waiting_keyframes_;
  std::deque<landmark_loop_closure::LoopClosureConstPtr> waiting_loops_;
  ros::Subscriber truth_subscriber_;
  ros::Subscriber verdict_subscriber_;
  std::vector<ros::Subscriber> subscribers_;
  /// Keyed by the loop's two stamps: keyframe ids repeat between robots.
  std::map<std::pair<ros::Time, ros::Time>, std::pair<bool, bool>> graph_verdicts_;
  std::map<std::string, nav_msgs::PathConstPtr> corrected_paths_;  ///< By robot ("": the one).
  std::map<std::string, std::vector<std::pair<ros::Time, geometry_msgs::Pose>>> keyframe_odometry_;
  Eigen::Isometry3d camera_in_base_ = Eigen::Isometry3d::Identity();
  std::map<ros::Time, geometry_msgs::Pose> truth_;
  std::map<ros::Time, geometry_msgs::Point> keyframe_truth_;
  int keyframes_ = 0;
  int revisited_keyframes_ = 0;
  int loops_ = 0;
  int true_loops_ = 0;
  int loops_between_robots_ = 0;
  int posed_loops_between_robots_ = 0;
  int true_loops_between_robots_ = 0;
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
