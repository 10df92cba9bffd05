// loop_injector: a test tool that makes wrong loops. It passes the detector's loop closures on
// (loop_closures -> loop_closures_injected) and replaces a share of them (~wrong_fraction,
// drawn with ~seed) by a wrong one: the match id and stamp of a random earlier keyframe at least
// ~min_id_distance ids from the true match, the relative pose and covariance left as published
// (plausible, but for another place). Each replacement is said in one INFO line.
#include <random>
#include <vector>

#include <ros/ros.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopClosure.h"

namespace {

class LoopInjector {
 public:
  LoopInjector(ros::NodeHandle& node, ros::NodeHandle& private_node) {
    int seed = 5;
    private_node.param("wrong_fraction", wrong_fraction_, wrong_fraction_);
    private_node.param("min_id_distance", min_id_distance_, min_id_distance_);
    private_node.param("seed", seed, seed);
    random_.seed(static_cast<uint32_t>(seed));
    publisher_ = node.advertise<landmark_loop_closure::LoopClosure>("loop_closures_injected", 100);
    keyframe_subscriber_ = node.subscribe("keyframes", 1000, &LoopInjector::onKeyframe, this);
    loop_subscriber_ = node.subscribe("loop_closures", 100, &LoopInjector::onLoop, this);
  }

 private:
  void onKeyframe(const landmark_loop_closure::Keyframe& keyframe) {
    keyframes_.push_back({keyframe.id, keyframe.header.stamp});
  }

  void onLoop(const landmark_loop_closure::LoopClosure& loop) {
    landmark_loop_closure::LoopClosure out = loop;
    if (std::uniform_real_distribution<double>(0.0, 1.0)(random_) < wrong_fraction_) {
      std::vector<size_t> far;
      for (size_t i = 0; i < keyframes_.size(); ++i) {
        const long gap = static_cast<long>(keyframes_[i].first) - static_cast<long>(loop.match_id);
        if (keyframes_[i].first < loop.query_id && std::labs(gap) >= min_id_distance_) {
          far.push_back(i);
        }
      }
      if (!far.empty()) {
        const size_t pick = far[std::uniform_int_distribution<size_t>(0, far.size() - 1)(random_)];
        out.match_id = keyframes_[pick].first;
        out.match_stamp = keyframes_[pick].second;
        ROS_INFO("Injected a wrong loop: keyframe %lu -> %lu (the detector said %lu)",
                 static_cast<unsigned long>(out.query_id), static_cast<unsigned long>(out.match_id),
                 static_cast<unsigned long>(loop.match_id));
      }
    }
    publisher_.publish(out);
  }

  double wrong_fraction_ = 0.05;
  int min_id_distance_ = 20;
  std::mt19937 random_;
  std::vector<std::pair<uint64_t, ros::Time>> keyframes_;
  ros::Publisher publisher_;
  ros::Subscriber keyframe_subscriber_;
  ros::Subscriber loop_subscriber_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "loop_injector");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  LoopInjector injector(node, private_node);
  ros::spin();
  return 0;
}
