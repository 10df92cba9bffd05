// Standalone executable: loads the nodelet into its own process.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "loop_closure");
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "landmark_loop_closure/LoopClosureNodelet",
                   remappings, arguments)) {
    return 1;  // The nodelet said why in one FATAL line.
  }
  ros::spin();
  return 0;
}
