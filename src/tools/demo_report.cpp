// Prints every loop closure the detector publishes as TRUE or FALSE against ground truth, and a
// summary at shutdown. Ground truth: nav_msgs/Odometry on `ground_truth`; a loop is true when
// the true positions at its two stamps are within ~true_loop_distance metres.
#include <cmath>
#include <cstdio>
#include <map>

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopClosure.h"

namespace {

class DemoReport {
 public:
  explicit DemoReport(ros::NodeHandle& node, ros::NodeHandle& private_node) {
    private_node.param("true_loop_distance", true_loop_distance_, 2.5);
    private_node.param("revisit_min_seconds", revisit_min_seconds_, 20.0);
    truth_subscriber_ = node.subscribe("ground_truth", 1000, &DemoReport::onTruth, this);
    loop_subscriber_ = node.subscribe("loop_closures", 100, &DemoReport::onLoop, this);
    keyframe_subscriber_ = node.subscribe("keyframes", 1000, &DemoReport::onKeyframe, this);
  }

  void printSummary() const {
    const int false_loops = loops_ - true_loops_;
    std::printf("\n==== demo summary ====\n");
    std::printf("keyframes:            %d\n", keyframes_);
    std::printf("revisited keyframes:  %d (a keyframe >= %.0f s older lies within %.1f m)\n",
                revisited_keyframes_, revisit_min_seconds_, true_loop_distance_);
    std::printf("loops published:      %d (true %d, false %d)\n", loops_, true_loops_, false_loops);
    if (loops_ > 0) {
      std::printf("precision:            %.3f\n", static_cast<double>(true_loops_) / loops_);
    }
    if (revisited_keyframes_ > 0) {
      std::printf("recall (keyframes):   %.3f\n",
                  static_cast<double>(true_loops_) / revisited_keyframes_);
    }
    std::fflush(stdout);
  }

 private:
  bool truthAt(const ros::Time& stamp, geometry_msgs::Point* position) const {
    if (truth_.empty()) return false;
    auto it = truth_.lower_bound(stamp);
    if (it == truth_.end()) it = std::prev(it);
    if (it != truth_.begin()) {
      const auto before = std::prev(it);
      if ((stamp - before->first) < (it->first - stamp)) it = before;
    }
    if (std::abs((it->first - stamp).toSec()) > 0.5) return false;
    *position = it->second;
    return true;
  }

  void onTruth(const nav_msgs::OdometryConstPtr& truth) {
    truth_[truth->header.stamp] = truth->pose.pose.position;
  }

  void onKeyframe(const landmark_loop_closure::KeyframeConstPtr& keyframe) {
    ++keyframes_;
    geometry_msgs::Point here;
    if (!truthAt(keyframe->header.stamp, &here)) return;
    for (const auto& [stamp, position] : keyframe_truth_) {
      if ((keyframe->header.stamp - stamp).toSec() < revisit_min_seconds_) break;
      if (std::hypot(position.x - here.x, position.y - here.y) < true_loop_distance_) {
        ++revisited_keyframes_;
        break;
      }
    }
    keyframe_truth_[keyframe->header.stamp] = here;
  }

  void onLoop(const landmark_loop_closure::LoopClosureConstPtr& loop) {
    ++loops_;
    geometry_msgs::Point query;
    geometry_msgs::Point match;
    if (!truthAt(loop->query_stamp, &query) || !truthAt(loop->match_stamp, &match)) {
      std::printf("loop %lu -> %lu: no ground truth at its stamps\n",
                  static_cast<unsigned long>(loop->query_id),
                  static_cast<unsigned long>(loop->match_id));
      return;
    }
    const double distance = std::hypot(query.x - match.x, query.y - match.y);
    const bool is_true = distance < true_loop_distance_;
    true_loops_ += is_true ? 1 : 0;
    std::printf("loop keyframe %4lu -> %4lu  score %.3f  true distance %5.2f m  %s\n",
                static_cast<unsigned long>(loop->query_id),
                static_cast<unsigned long>(loop->match_id), loop->score, distance,
                is_true ? "TRUE" : "FALSE");
    std::fflush(stdout);
  }

  double true_loop_distance_ = 2.5;
  double revisit_min_seconds_ = 20.0;
  ros::Subscriber truth_subscriber_;
  ros::Subscriber loop_subscriber_;
  ros::Subscriber keyframe_subscriber_;
  std::map<ros::Time, geometry_msgs::Point> truth_;
  std::map<ros::Time, geometry_msgs::Point> keyframe_truth_;
  int keyframes_ = 0;
  int revisited_keyframes_ = 0;
  int loops_ = 0;
  int true_loops_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "demo_report");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  DemoReport report(node, private_node);
  ros::spin();
  report.printSummary();
  return 0;
}
