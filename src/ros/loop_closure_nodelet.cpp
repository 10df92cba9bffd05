// The nodelet only builds the node; everything else lives in LoopClosureNode.
#include <memory>
#include <stdexcept>

#include <nodelet/nodelet.h>
#include <ros/package.h>
#include <pluginlib/class_list_macros.hpp>

#include "landmark_loop_closure/common/model_directory.h"
#include "loop_closure_node.h"

namespace landmark_loop_closure {

class LoopClosureNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    // The package's models through the ROS package path: the source tree or the install space.
    const std::string package = ros::package::getPath("landmark_loop_closure");
    if (!package.empty()) setModelDirectory(package + "/model");
    NodeOptions options;
    try {
      options = loadNodeOptions(getPrivateNodeHandle());
    } catch (const std::invalid_argument& problems) {
      NODELET_FATAL("Refusing to start, fix these parameters:\n%s", problems.what());
      throw;
    }
    try {
      node_ = std::make_unique<LoopClosureNode>(getNodeHandle(), getPrivateNodeHandle(), options);
    } catch (const std::runtime_error& error) {
      NODELET_FATAL("Refusing to start: %s", error.what());
      throw;
    }
  }

  std::unique_ptr<LoopClosureNode> node_;
};

}  // namespace landmark_loop_closure

PLUGINLIB_EXPORT_CLASS(landmark_loop_closure::LoopClosureNodelet, nodelet::Nodelet)
