// The bag source of lcd_evaluate keeps the keyframes the node would keep.
#include <algorithm>
#include <filesystem>

#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>

#include "../../src/bag/bag_source.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

nav_msgs::Odometry odometry(double x, const ros::Time& stamp) {
  nav_msgs::Odometry message;
  message.header.stamp = stamp;
  message.header.frame_id = "odom";
  message.pose.pose.position.x = x;
  message.pose.pose.orientation.w = 1.0;
  return message;
}

// 50 frames at 10 Hz moving 0.1 m each; frame 20 has a bad encoding; frame 30 has no odometry
// message of its own (its pose is interpolated between 29's and 31's, 0.2 s apart); frames 40-42
// have none either, and 39's and 43's are 0.4 s apart, more than odometry_max_interval.
std::string writeBag() {
  const fs::path path = fs::temp_directory_path() / "lcd_bag_source.bag";
  rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
  for (int i = 0; i < 50; ++i) {
    const ros::Time stamp(100.0 + 0.1 * i);
    std_msgs::Header header;
    header.stamp = stamp;
    auto image =
        cv_bridge::CvImage(header, "mono8", cv::Mat(48, 64, CV_8UC1, cv::Scalar(i))).toImageMsg();
    if (i == 20) image->encoding = "32FC1";
    bag.write("/camera/image_raw", stamp, image);
    if (i != 30 && (i < 40 || i > 42)) bag.write("/odom", stamp, odometry(0.1 * i, stamp));
    bag.write("/ground_truth", stamp, odometry(0.1 * i + 5.0, stamp));
  }
  bag.close();
  return path.string();
}

}  // namespace

TEST(BagSource, KeepsTheKeyframesOfTheMotionRule) {
  BagSourceOptions options;
  options.path = writeBag();
  options.truth_topic = "/ground_truth";
  const BagKeyframes keyframes = readBagKeyframes(options);
  EXPECT_EQ(keyframes.images_read, 50u);
  EXPECT_EQ(keyframes.images_without_odometry, 3u);
  EXPECT_EQ(keyframes.images_rejected, 1u);
  // 0.1 m per frame, a keyframe every 0.3 m: frames 0, 3, 6, ... (21 after the bad frame 20,
  // 43 after the gap).
  ASSERT_GE(keyframes.images.size(), 14u);  // Frames 40-42 are gone.
  ASSERT_LE(keyframes.images.size(), 17u);
  EXPECT_EQ(keyframes.truth.size(), keyframes.images.size());
  EXPECT_DOUBLE_EQ(keyframes.truth[1].position.x() - keyframes.odometry[1].position.x(), 5.0);
  EXPECT_EQ(keyframes.images[1].at<uchar>(0, 0), 3);
  for (size_t k = 0; k < keyframes.images.size(); ++k) {
    EXPECT_NEAR(keyframes.odometry[k].position.x(), 0.1 * keyframes.images[k].at<uchar>(0, 0),
                1e-9);
  }
  // Every image as the node receives it: frame 30's pose interpolated to its own stamp, frames
  // 40-42 dropped.
  std::vector<int> played;
  playBagFrames(options, false, [&](size_t, const eval::DetectorFrame& frame, const Pose&) {
    const int value = frame.image.at<uchar>(0, 0);
    played.push_back(value);
    EXPECT_NEAR(frame.pose.position.x(), 0.1 * value, 1e-9) << "frame " << value;
  });
  EXPECT_NE(std::find(played.begin(), played.end(), 30), played.end());
  EXPECT_EQ(std::find(played.begin(), played.end(), 41), played.end());
  EXPECT_EQ(played.size(), 46u);  // 50 less the bad frame 20 and frames 40-42.
  EXPECT_EQ(keyframes.keyframes_without_truth, 0u);
}

TEST(BagSource, MissingBagOrTopicIsAClearError) {
  BagSourceOptions options;
  options.path = "/nonexistent.bag";
  EXPECT_THROW(readBagKeyframes(options), std::runtime_error);
  options.path = writeBag();
  options.odom_topic = "/nothing";
  try {
    readBagKeyframes(options);
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/nothing"), std::string::npos);
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
