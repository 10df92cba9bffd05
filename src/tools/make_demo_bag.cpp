// Writes a rosbag of a camera driven around the generated corridor: images, camera_info,
// drifting odometry (and its tf), and ground truth.
// Usage: make_demo_bag OUTPUT.bag [laps=2] [frames per second=10]
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_msgs/TFMessage.h>

#include "landmark_loop_closure/sim/sequence.h"

namespace {

using landmark_loop_closure::sim::CameraModel;
using landmark_loop_closure::sim::CorridorWorld;
using landmark_loop_closure::sim::Pose2D;
using landmark_loop_closure::sim::SequenceFrame;
using landmark_loop_closure::sim::SequenceGenerator;
using landmark_loop_closure::sim::SequenceOptions;

geometry_msgs::Pose toPose(const Pose2D& pose) {
  geometry_msgs::Pose result;
  result.position.x = pose.x;
  result.position.y = pose.y;
  result.orientation.z = std::sin(0.5 * pose.yaw);
  result.orientation.w = std::cos(0.5 * pose.yaw);
  return result;
}

nav_msgs::Odometry toOdometry(const Pose2D& pose, const ros::Time& stamp,
                              const std::string& frame) {
  nav_msgs::Odometry odometry;
  odometry.header.stamp = stamp;
  odometry.header.frame_id = frame;
  odometry.child_frame_id = "base_link";
  odometry.pose.pose = toPose(pose);
  return odometry;
}

sensor_msgs::CameraInfo cameraInfo(const CameraModel& camera, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(camera.width);
  info.height = static_cast<uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  const double cx = 0.5 * (camera.width - 1);
  const double cy = 0.5 * (camera.height - 1);
  info.K = {camera.focal_px, 0, cx, 0, camera.focal_px, cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {camera.focal_px, 0, cx, 0, 0, camera.focal_px, cy, 0, 0, 0, 1, 0};
  return info;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: make_demo_bag OUTPUT.bag [laps=2] [frames per second=10] [odometry "
                 "scale error=0.02] [odometry heading drift, rad/m=0.004]\n";
    return 2;
  }
  const std::string path = argv[1];
  SequenceOptions options;
  if (argc > 2) options.laps = std::atof(argv[2]);
  if (argc > 3) options.rate = std::atof(argv[3]);
  if (argc > 4) options.odom_scale_error = std::atof(argv[4]);
  if (argc > 5) options.odom_yaw_drift_per_metre = std::atof(argv[5]);
  if (!(options.laps > 0.0) || !(options.rate > 0.0 && options.rate <= 1000.0)) {
    std::cerr << "laps must be > 0 and frames per second in (0, 1000]\n";
    return 2;
  }
  if (!(std::abs(options.odom_scale_error) < 0.5) ||
      !(std::abs(options.odom_yaw_drift_per_metre) < 0.1)) {
    std::cerr << "the odometry scale error must be within +-0.5 and the heading drift within "
                 "+-0.1 rad/m\n";
    return 2;
  }
  ros::Time::init();
  const CorridorWorld world;
  const CameraModel camera;
  SequenceGenerator sequence(world, camera, options);

  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& error) {
    std::cerr << "cannot write " << path << ": " << error.what() << "\n";
    return 1;
  }
  SequenceFrame frame;
  while (sequence.next(&frame)) {
    const ros::Time stamp(frame.stamp);
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = "camera";
    bag.write("/camera/image_raw", stamp,
              cv_bridge::CvImage(header, "mono8", frame.image).toImageMsg());
    bag.write("/camera/camera_info", stamp, cameraInfo(camera, header));
    const nav_msgs::Odometry odometry = toOdometry(frame.odom, stamp, "odom");
    bag.write("/odom", stamp, odometry);
    bag.write("/ground_truth", stamp, toOdometry(frame.truth, stamp, "world"));
    geometry_msgs::TransformStamped transform;
    transform.header = odometry.header;
    transform.child_frame_id = "base_link";
    transform.transform.translation.x = odometry.pose.pose.position.x;
    transform.transform.translation.y = odometry.pose.pose.position.y;
    transform.transform.rotation = odometry.pose.pose.orientation;
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(transform);
    bag.write("/tf", stamp, tf);
    if (frame.index % 200 == 0) {
      std::cout << "make_demo_bag: frame " << frame.index << " / " << sequence.size() << "\n";
    }
  }
  bag.close();
  std::cout << "make_demo_bag: wrote " << sequence.size() << " frames at " << options.rate
            << " Hz (" << options.laps << " laps of " << world.lapLength() << " m) to " << path
            << "\n";
  return 0;
}
