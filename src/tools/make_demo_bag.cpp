// Writes a rosbag of a camera driven around the generated corridor: images, camera_info,
// drifting odometry (and its tf), and ground truth.
// Usage: make_demo_bag OUTPUT.bag [laps=2] [frames per second=10] [scale error] [heading drift]
//        make_demo_bag --two-robots OUTPUT.bag [frames per second=10]
//        make_demo_bag --traversals A_DIR B_DIR OUTPUT.bag
// --two-robots: robot_a drives lap 1 and on to where it started (1.2 laps), then robot_b drives
// one lap from 0.3 laps in, in an odometry frame of its own that starts at its first pose; each
// robot's topics under /robot_a or /robot_b, the ground truth of both on /ground_truth.
// --traversals: two walks of one route as two robots, a frame a second (Gardens Point: image i of
// each folder shows place i): robot_a plays A_DIR's images in name order, then robot_b B_DIR's.
// The images come without odometry: place i is put i metres along x, for the odometry and the
// ground truth alike (a keyframe each image). camera_info: the phone camera of
// bench/cameras/gardens_point.yaml (fx = 800 px at 960 px wide), scaled to each image's width.
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <algorithm>
#include <filesystem>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>

#include "command_line.h"
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

/// Writes one frame's image, camera_info and odometry under the topic prefix (odometry and
/// optionally its tf in odom_frame), and its truth on /ground_truth.
void writeFrame(rosbag::Bag* bag, const std::string& prefix, const std::string& odom_frame,
                bool with_tf, const CameraModel& camera, const SequenceFrame& frame,
                const Pose2D& odometry_pose) {
  const ros::Time stamp(frame.stamp);
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = prefix.empty() ? "camera" : prefix.substr(1) + "/camera";
  const std::string encoding = frame.image.channels() == 3 ? "bgr8" : "mono8";
  bag->write(prefix + "/camera/image_raw", stamp,
             cv_bridge::CvImage(header, encoding, frame.image).toImageMsg());
  bag->write(prefix + "/camera/camera_info", stamp, cameraInfo(camera, header));
  const nav_msgs::Odometry odometry = toOdometry(odometry_pose, stamp, odom_frame);
  bag->write(prefix + "/odom", stamp, odometry);
  bag->write("/ground_truth", stamp, toOdometry(frame.truth, stamp, "world"));
  if (!with_tf) return;
  geometry_msgs::TransformStamped transform;
  transform.header = odometry.header;
  transform.child_frame_id = "base_link";
  transform.transform.translation.x = odometry.pose.pose.position.x;
  transform.transform.translation.y = odometry.pose.pose.position.y;
  transform.transform.rotation = odometry.pose.pose.orientation;
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(transform);
  bag->write("/tf", stamp, tf);
}

/// pose expressed in the frame whose origin is `origin`.
Pose2D relativeTo(const Pose2D& origin, const Pose2D& pose) {
  const double dx = pose.x - origin.x, dy = pose.y - origin.y;
  const double c = std::cos(origin.yaw), s = std::sin(origin.yaw);
  return Pose2D{c * dx + s * dy, -s * dx + c * dy,
                std::remainder(pose.yaw - origin.yaw, 2.0 * M_PI)};
}

/// Opens `path` for writing; says why not on stderr.
bool openForWriting(rosbag::Bag* bag, const std::string& path) {
  try {
    bag->open(path, rosbag::bagmode::Write);
    return true;
  } catch (const rosbag::BagException& error) {
    std::cerr << "cannot write " << path << ": " << error.what() << "\n";
    return false;
  }
}

/// The images of a folder (.jpg, .jpeg, .png), in name order.
std::vector<std::string> imagesIn(const std::string& folder) {
  std::vector<std::string> paths;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    std::string extension = entry.path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension == ".jpg" || extension == ".jpeg" || extension == ".png") {
      paths.push_back(entry.path().string());
    }
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

/// --traversals: robot_a plays `folder_a`, then robot_b `folder_b`, a frame a second.
int writeTraversals(const std::string& folder_a, const std::string& folder_b,
                    const std::string& path) {
  const std::vector<std::string> images_a = imagesIn(folder_a);
  const std::vector<std::string> images_b = imagesIn(folder_b);
  for (const auto& [folder, images] : {std::pair{&folder_a, &images_a}, {&folder_b, &images_b}}) {
    if (images->empty()) {
      std::cerr << "no .jpg or .png images in " << *folder << "\n";
      return 2;
    }
  }
  rosbag::Bag bag;
  if (!openForWriting(&bag, path)) return 1;
  constexpr double kStart = 1700000000.0;
  // robot_b starts a minute after robot_a's last image.
  const double robot_b_start = kStart + static_cast<double>(images_a.size()) + 60.0;
  for (const auto& [robot, images, start] :
       {std::tuple{"/robot_a", &images_a, kStart}, {"/robot_b", &images_b, robot_b_start}}) {
    for (size_t i = 0; i < images->size(); ++i) {
      SequenceFrame frame;
      frame.index = i;
      frame.stamp = start + static_cast<double>(i);
      frame.image = cv::imread((*images)[i], cv::IMREAD_COLOR);
      if (frame.image.empty()) {
        std::cerr << "cannot read " << (*images)[i] << "\n";
        return 1;
      }
      frame.truth = Pose2D{static_cast<double>(i), 0.0, 0.0};
      CameraModel camera;
      camera.width = frame.image.cols;
      camera.height = frame.image.rows;
      camera.focal_px = 800.0 * frame.image.cols / 960.0;
      writeFrame(&bag, robot, std::string(robot + 1) + "/odom", false, camera, frame, frame.truth);
    }
  }
  bag.close();
  std::cout << "make_demo_bag: wrote robot_a's " << images_a.size() << " images of " << folder_a
            << " and robot_b's " << images_b.size() << " of " << folder_b << " to " << path << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  std::optional<double> laps, rate, scale_error, heading_drift;
  bool two_robots = false;
  std::vector<std::string> traversals;
  CLI::App app{
      "A rosbag of a camera driven around the generated corridor (images, camera_info, drifting "
      "odometry and its tf, ground truth); or two robots on it; or two image folders as two "
      "robots."};
  app.add_option("OUTPUT", path, "the bag to write")->required();
  app.add_option("LAPS", laps,
                 "laps driven (default 2); with --two-robots: frames per second (default 10)");
  app.add_option("RATE", rate, "frames per second (default 10)");
  app.add_option("SCALE_ERROR", scale_error, "odometry scale error (default 0.02)");
  app.add_option("HEADING_DRIFT", heading_drift, "odometry heading drift, rad/m (default 0.004)");
  app.add_flag("--two-robots", two_robots,
               "robot_a drives 1.2 laps, then robot_b one lap from 0.3 laps in, in an odometry "
               "frame of its own; topics under /robot_a and /robot_b");
  app.add_option("--traversals", traversals,
                 "A_DIR B_DIR: two walks of one route as two robots, a frame a second, image i of "
                 "each folder at i metres")
      ->expected(2)
      ->excludes("--two-robots");
  if (const auto exit_code = landmark_loop_closure::tools::parseCommandLine(&app, argc, argv))
    return *exit_code;
  if (!traversals.empty() || two_robots) {
    if (rate || scale_error || heading_drift || (!traversals.empty() && laps)) {
      std::cerr << "make_demo_bag: --two-robots takes OUTPUT [frames per second], --traversals "
                   "A_DIR B_DIR OUTPUT alone\n";
      return 2;
    }
  }
  if (!traversals.empty()) {
    ros::Time::init();
    return writeTraversals(traversals[0], traversals[1], path);
  }
  SequenceOptions options;
  if (two_robots) {
    options.laps = 2.3;  // robot_a 0-1.2 laps, robot_b 1.3-2.3: one lap from 0.3 laps in.
    if (laps) options.rate = *laps;
  } else {
    options.laps = laps.value_or(options.laps);
    options.rate = rate.value_or(options.rate);
    options.odom_scale_error = scale_error.value_or(options.odom_scale_error);
    options.odom_yaw_drift_per_metre = heading_drift.value_or(options.odom_yaw_drift_per_metre);
  }
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
  if (!openForWriting(&bag, path)) return 1;
  const size_t lap_frames =
      static_cast<size_t>(static_cast<double>(sequence.size()) / options.laps);
  const size_t robot_a_end = lap_frames * 12 / 10;
  const size_t robot_b_start = lap_frames * 13 / 10;
  Pose2D robot_b_origin;
  size_t written = 0;
  SequenceFrame frame;
  while (sequence.next(&frame, !two_robots)) {
    if (two_robots) {
      if (frame.index >= robot_a_end && frame.index < robot_b_start) continue;
      frame.image = sequence.render(frame);
      if (frame.index < robot_a_end) {
        writeFrame(&bag, "/robot_a", "robot_a/odom", false, camera, frame, frame.odom);
      } else {
        if (frame.index == robot_b_start) robot_b_origin = frame.odom;
        writeFrame(&bag, "/robot_b", "robot_b/odom", false, camera, frame,
                   relativeTo(robot_b_origin, frame.odom));
      }
    } else {
      writeFrame(&bag, "", "odom", true, camera, frame, frame.odom);
    }
    ++written;
    if (frame.index % 200 == 0) {
      std::cout << "make_demo_bag: frame " << frame.index << " / " << sequence.size() << "\n";
    }
  }
  bag.close();
  std::cout << "make_demo_bag: wrote " << written << " frames at " << options.rate << " Hz ("
            << (two_robots ? "two robots, " : "") << options.laps << " laps of "
            << world.lapLength() << " m) to " << path << "\n";
  return 0;
}
