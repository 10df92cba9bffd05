// The running node pairs each image with the odometry at the image's own stamp: odometry of
// another frame than base_frame is turned into base_frame's pose through tf, and messages that
// do not share the images' stamps (here 20 Hz against 10 Hz images, 25 ms off) are interpolated.
// The nearest message would be 2.5 cm off, and the odometry frame's pose 0.5 m off.
#include <cmath>
#include <map>
#include <random>

#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include "landmark_loop_closure/Keyframe.h"

namespace {

constexpr double kStart = 1000.0;
constexpr double kSpeed = 1.0;     // m/s along x.
constexpr double kImuAhead = 0.5;  // The odometry's frame sits 0.5 m ahead of base_link.
constexpr int kImages = 60;        // 10 Hz: 6 s, a keyframe every 0.3 m.

double imuX(double stamp) { return kSpeed * (stamp - kStart); }

}  // namespace

TEST(LoopClosureNode, ImagesGetTheOdometryAtTheirOwnStampInBaseFrame) {
  ros::NodeHandle node;
  ros::Publisher images = node.advertise<sensor_msgs::Image>("/camera/image_raw", 100);
  ros::Publisher odometry = node.advertise<nav_msgs::Odometry>("/odom", 100);
  ros::Publisher static_tf = node.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  std::map<double, landmark_loop_closure::Keyframe> keyframes;
  ros::Subscriber keyframe_subscriber = node.subscribe<landmark_loop_closure::Keyframe>(
      "/keyframes", 100, [&](const landmark_loop_closure::KeyframeConstPtr& keyframe) {
        keyframes[keyframe->header.stamp.toSec()] = *keyframe;
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && ros::WallTime::now() < deadline &&
         (images.getNumSubscribers() == 0 || odometry.getNumSubscribers() == 0 ||
          keyframe_subscriber.getNumPublishers() == 0)) {
    ros::WallDuration(0.1).sleep();
  }
  ASSERT_GT(odometry.getNumSubscribers(), 0u) << "the node did not subscribe";

  geometry_msgs::TransformStamped mount;  // base_link -> imu: the odometry's body.
  mount.header.frame_id = "base_link";
  mount.child_frame_id = "imu";
  mount.transform.translation.x = kImuAhead;
  mount.transform.rotation.w = 1.0;
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(mount);
  static_tf.publish(tf);
  ros::WallDuration(0.5).sleep();

  std::mt19937 random(7);
  std::uniform_int_distribution<int> grey(0, 255);
  const auto publishOdometry = [&](double stamp) {
    nav_msgs::Odometry message;
    message.header.stamp = ros::Time(stamp);
    message.header.frame_id = "odom";
    message.child_frame_id = "imu";
    message.pose.pose.position.x = imuX(stamp);
    message.pose.pose.orientation.w = 1.0;
    odometry.publish(message);
  };
  publishOdometry(kStart - 0.025);
  for (int i = 0; i < kImages; ++i) {
    const double stamp = kStart + 0.1 * i;
    cv::Mat pixels(120, 160, CV_8UC1);
    for (int k = 0; k < pixels.rows * pixels.cols; ++k) pixels.data[k] = grey(random);
    std_msgs::Header header;
    header.stamp = ros::Time(stamp);
    header.frame_id = "camera";
    images.publish(cv_bridge::CvImage(header, "mono8", pixels).toImageMsg());
    // Visual odometry answers after the image: the messages around it come later.
    publishOdometry(stamp + 0.025);
    publishOdometry(stamp + 0.075);
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  const ros::WallTime quiet = ros::WallTime::now() + ros::WallDuration(5.0);
  while (ros::ok() && ros::WallTime::now() < quiet) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  // A keyframe every 0.3 m over 5.9 m.
  ASSERT_GE(keyframes.size(), 15u);
  for (const auto& [stamp, keyframe] : keyframes) {
    EXPECT_NEAR(keyframe.pose.position.x, imuX(stamp) - kImuAhead, 1e-6) << "image at " << stamp;
    EXPECT_NEAR(keyframe.pose.orientation.w, 1.0, 1e-9);
    EXPECT_EQ(keyframe.header.frame_id, "odom");
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_odometry");
  return RUN_ALL_TESTS();
}
