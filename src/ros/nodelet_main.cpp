// Standalone executable: loads one of the package's nodelets (NODELET_TYPE, compiled in) into
// its own process under NODE_NAME.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, NODE_NAME);
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), NODELET_TYPE, remappings, arguments)) {
    return 1;  // The nodelet said why in one FATAL line.
  }
  ros::spin();
  return 0;
}
