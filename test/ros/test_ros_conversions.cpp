#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>
#include <Eigen/Geometry>

#include "../../fuzz/image_message_input.h"
#include "../../src/messages/ros_conversions.h"
#include "../../src/ros/loop_markers.h"
#include "../../src/ros/ros_parameter_source.h"
#include "../core/kept_fuzz_inputs.h"

using namespace landmark_loop_closure;

namespace {

sensor_msgs::Image makeImage(const std::string& encoding, uint32_t width, uint32_t height,
                             uint32_t pixel_bytes) {
  sensor_msgs::Image image;
  image.header.stamp = ros::Time(1.0);
  image.encoding = encoding;
  image.width = width;
  image.height = height;
  image.step = width * pixel_bytes;
  image.data.assign(static_cast<size_t>(image.step) * height, 0);
  return image;
}

}  // namespace

TEST(RosConversions, PoseRoundTrip) {
  Pose pose;
  pose.position = Eigen::Vector3d(1.5, -2.0, 0.25);
  pose.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Pose back = fromRos(toRos(pose));
  EXPECT_TRUE(back.position.isApprox(pose.position));
  EXPECT_TRUE(back.orientation.isApprox(pose.orientation));
}

TEST(RosConversions, FromRosKeepsAnUnnormalisedQuaternionForTheCheckToSee) {
  geometry_msgs::Pose message;
  message.orientation.w = 2.0;
  EXPECT_DOUBLE_EQ(fromRos(message).orientation.norm(), 2.0);
}

TEST(RosConversions, SupportedEncodingsConvertToGrey) {
  namespace enc = sensor_msgs::image_encodings;
  const std::pair<std::string, uint32_t> encodings[] = {{enc::MONO8, 1}, {enc::MONO16, 2},
                                                        {enc::BGR8, 3},  {enc::RGB8, 3},
                                                        {enc::BGRA8, 4}, {enc::RGBA8, 4}};
  for (const auto& [encoding, bytes] : encodings) {
    sensor_msgs::Image image = makeImage(encoding, 64, 48, bytes);
    image.data.assign(image.data.size(), 200);
    ASSERT_FALSE(checkImageMessage(image)) << encoding;
    const cv::Mat grey = toGrey(image);
    EXPECT_EQ(grey.type(), CV_8UC1) << encoding;
    EXPECT_EQ(grey.size(), cv::Size(64, 48)) << encoding;
  }
}

TEST(RosConversions, RgbAndBgrAreNotConfused) {
  sensor_msgs::Image red_rgb = makeImage(sensor_msgs::image_encodings::RGB8, 16, 16, 3);
  for (size_t i = 0; i < red_rgb.data.size(); i += 3) red_rgb.data[i] = 255;
  sensor_msgs::Image red_bgr = makeImage(sensor_msgs::image_encodings::BGR8, 16, 16, 3);
  for (size_t i = 2; i < red_bgr.data.size(); i += 3) red_bgr.data[i] = 255;
  EXPECT_EQ(toGrey(red_rgb).at<uchar>(0, 0), toGrey(red_bgr).at<uchar>(0, 0));
}

TEST(RosConversions, ColourReachesDescriptorsAsBgr) {
  namespace enc = sensor_msgs::image_encodings;
  sensor_msgs::Image red_rgb = makeImage(enc::RGB8, 16, 16, 3);
  for (size_t i = 0; i < red_rgb.data.size(); i += 3) red_rgb.data[i] = 255;
  sensor_msgs::Image red_rgba = makeImage(enc::RGBA8, 16, 16, 4);
  for (size_t i = 0; i < red_rgba.data.size(); i += 4) red_rgba.data[i] = 255;
  for (const sensor_msgs::Image& image : {red_rgb, red_rgba}) {
    const cv::Mat bgr = toBgr(image);
    ASSERT_EQ(bgr.type(), CV_8UC3);
    EXPECT_EQ(bgr.at<cv::Vec3b>(5, 5), cv::Vec3b(0, 0, 255)) << image.encoding;
  }
  sensor_msgs::Image grey = makeImage(enc::MONO16, 8, 8, 2);
  grey.data.assign(grey.data.size(), 0x80);  // 0x8080 -> 128 in 8 bits.
  EXPECT_EQ(toBgr(grey).at<cv::Vec3b>(1, 1), cv::Vec3b(128, 128, 128));
}

TEST(RosConversions, UnsupportedEncodingIsNamed) {
  const sensor_msgs::Image image = makeImage("32FC1", 64, 48, 4);
  const auto error = checkImageMessage(image);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kUnsupportedImageType);
  EXPECT_NE(error->message.find("32FC1"), std::string::npos);
}

TEST(RosConversions, TruncatedBuffersAreMalformedAndEmptyImagesEmpty) {
  sensor_msgs::Image image = makeImage(sensor_msgs::image_encodings::MONO8, 64, 48, 1);
  image.data.resize(100);
  std::optional<InputError> error = checkImageMessage(image);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kMalformedImage) << "truncated data is not 'empty'";
  EXPECT_NE(error->message.find("100 bytes"), std::string::npos) << error->message;
  image = makeImage(sensor_msgs::image_encodings::BGR8, 64, 48, 3);
  image.step = 64;  // Too short for 3 bytes per pixel.
  error = checkImageMessage(image);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kMalformedImage) << "a step mismatch is not 'empty'";
  EXPECT_NE(error->message.find("step 64"), std::string::npos) << error->message;
  error = checkImageMessage(makeImage(sensor_msgs::image_encodings::MONO8, 0, 0, 1));
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kEmptyImage);
}

TEST(RosConversions, AnImageWithStampZeroIsRefused) {
  sensor_msgs::Image image = makeImage(sensor_msgs::image_encodings::MONO8, 64, 48, 1);
  image.header.stamp = ros::Time();
  const auto error = checkImageMessage(image);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kUnsetStamp);
  EXPECT_NE(error->message.find("stamp is 0"), std::string::npos) << error->message;
}

TEST(RosConversions, LoopMessageCarriesEveryField) {
  AcceptedLoop loop;
  loop.query_id = 40;
  loop.query_stamp = 12.5;
  loop.match_id = 3;
  loop.match_stamp = 2.25;
  loop.score = 0.9;
  loop.global_score = 0.8;
  loop.rerank_score = 0.85;
  loop.consistent_keyframes = 4;
  loop.query_pose = planarPose(1, 2, 0.3);
  loop.match_pose = planarPose(1.1, 2.1, 0.2);
  const ros::Time query_stamp(1700000000, 123456789);
  const ros::Time match_stamp(1699999990, 987654321);
  const LoopClosure message = toLoopMsg(loop, query_stamp, match_stamp, "odom", "camera");
  EXPECT_EQ(message.header.frame_id, "odom");
  EXPECT_EQ(message.header.stamp, query_stamp);
  EXPECT_EQ(message.query_stamp, query_stamp);
  EXPECT_EQ(message.query_id, 40u);
  EXPECT_EQ(message.match_id, 3u);
  EXPECT_EQ(message.match_stamp, match_stamp);
  EXPECT_DOUBLE_EQ(message.score, 0.9);
  EXPECT_DOUBLE_EQ(message.global_score, 0.8);
  EXPECT_DOUBLE_EQ(message.rerank_score, 0.85);  // Its own stage, not a copy of score.
  EXPECT_EQ(message.consistent_frames, 4u);
  EXPECT_DOUBLE_EQ(message.match_pose.position.x, 1.1);
  EXPECT_FALSE(message.has_relative_pose);
}

TEST(RosConversions, VerifiedLoopCarriesItsRelativePoseAndCovariance) {
  AcceptedLoop loop;
  VerificationResult check;
  check.verdict = VerificationVerdict::kAccepted;
  check.inliers = 57;
  check.rms_error_px = 0.4;
  check.pose.rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  check.pose.translation = Eigen::Vector3d(0.6, 0.0, -0.8);
  check.pose.covariance(3, 3) = 1e-4;
  check.pose.covariance(0, 5) = check.pose.covariance(5, 0) = 2e-5;
  loop.verification = check;
  loop.relative_pose = check.pose;
  const LoopClosure message = toLoopMsg(loop, ros::Time(2.0), ros::Time(1.0), "odom", "camera");
  EXPECT_TRUE(message.verified);
  EXPECT_TRUE(message.has_relative_pose);
  EXPECT_FALSE(message.relative_pose_metric);
  EXPECT_EQ(message.inliers, 57u);
  EXPECT_DOUBLE_EQ(message.reprojection_error, 0.4);
  EXPECT_DOUBLE_EQ(message.relative_pose.pose.position.z, -0.8);
  EXPECT_NEAR(message.relative_pose.pose.orientation.y, std::sin(0.05), 1e-12);
  EXPECT_NEAR(message.relative_pose.pose.orientation.w, std::cos(0.05), 1e-12);
  EXPECT_DOUBLE_EQ(message.relative_pose.covariance[3 * 6 + 3], 1e-4);
  EXPECT_DOUBLE_EQ(message.relative_pose.covariance[0 * 6 + 5], 2e-5);
  EXPECT_DOUBLE_EQ(message.relative_pose.covariance[5 * 6 + 0], 2e-5);
  EXPECT_EQ(message.relative_pose_frame, "camera");
}

TEST(RosConversions, DepthImagesOf16And32BitsAreCopied) {
  std::string error;
  sensor_msgs::Image millimetres = makeImage("16UC1", 4, 3, 2);
  reinterpret_cast<uint16_t*>(millimetres.data.data())[5] = 1234;
  const cv::Mat depth16 = toDepth(millimetres, &error);
  ASSERT_EQ(depth16.type(), CV_16UC1) << error;
  EXPECT_EQ(depth16.at<uint16_t>(1, 1), 1234);
  EXPECT_EQ(toDepth(makeImage("mono16", 4, 3, 2), &error).type(), CV_16UC1);
  sensor_msgs::Image metres = makeImage("32FC1", 4, 3, 4);
  metres.step = 20;  // Padded rows.
  metres.data.assign(60, 0);
  reinterpret_cast<float*>(metres.data.data() + 20)[2] = 2.5f;
  const cv::Mat depth32 = toDepth(metres, &error);
  ASSERT_EQ(depth32.type(), CV_32FC1) << error;
  EXPECT_FLOAT_EQ(depth32.at<float>(1, 2), 2.5f);
  metres.data.clear();  // The copy does not point into the message.
  EXPECT_FLOAT_EQ(depth32.at<float>(1, 2), 2.5f);
}

TEST(RosConversions, UnusableDepthImagesSayWhy) {
  std::string error;
  std::string kind;
  EXPECT_TRUE(toDepth(makeImage("mono8", 4, 3, 1), &error, &kind).empty());
  EXPECT_NE(error.find("'mono8'"), std::string::npos) << error;
  EXPECT_EQ(kind, "depth_encoding");  // Each kind is throttled apart in the node's log.
  sensor_msgs::Image truncated = makeImage("32FC1", 4, 3, 4);
  truncated.data.resize(20);
  EXPECT_TRUE(toDepth(truncated, &error, &kind).empty());
  EXPECT_NE(error.find("20-byte buffer"), std::string::npos) << error;
  EXPECT_EQ(kind, "depth_size");
  EXPECT_TRUE(toDepth(makeImage("16UC1", 0, 0, 2), &error).empty());
  // Found by scripts/fuzz.sh: rows that do not start on a sample made OpenCV throw.
  sensor_msgs::Image odd_step = makeImage("16UC1", 4, 3, 2);
  odd_step.step = 9;
  odd_step.data.assign(27, 0);
  EXPECT_TRUE(toDepth(odd_step, &error).empty());
  EXPECT_NE(error.find("step 9"), std::string::npos) << error;
  odd_step.encoding = "mono16";
  const auto refused = checkImageMessage(odd_step);
  ASSERT_TRUE(refused);
  EXPECT_NE(refused->message.find("2-byte samples"), std::string::npos) << refused->message;
  EXPECT_EQ(refused->code, InputErrorCode::kMalformedImage);
}

TEST(RosConversions, AnUntrustedPoseIsVerifiedButNotPublished) {
  AcceptedLoop loop;
  VerificationResult check;
  check.verdict = VerificationVerdict::kAccepted;
  check.inliers = 41;
  check.pose.translation = Eigen::Vector3d(1.0, 0.0, 0.0);
  loop.verification = check;  // Scale-free, publish_scale_free_pose off: no relative_pose.
  const LoopClosure message = toLoopMsg(loop, ros::Time(2.0), ros::Time(1.0), "odom", "camera");
  EXPECT_TRUE(message.verified);
  EXPECT_EQ(message.inliers, 41u);
  EXPECT_FALSE(message.has_relative_pose);
  EXPECT_DOUBLE_EQ(message.relative_pose.pose.position.x, 0.0);
  EXPECT_DOUBLE_EQ(message.relative_pose.pose.orientation.w, 1.0);
}

TEST(RosConversions, AMetricPoseReportsItsOwnInliersAndError) {
  AcceptedLoop loop;
  VerificationResult check;
  check.verdict = VerificationVerdict::kAmbiguous;  // Two views could not tell; PnP could.
  check.inliers = 48;
  check.rms_error_px = 0.3;
  loop.verification = check;
  MetricPoseResult metric;
  metric.found = true;
  metric.inliers = 35;
  metric.rms_error_px = 0.9;
  metric.pose.metric = true;
  metric.pose.translation = Eigen::Vector3d(0.2, 0.0, 0.45);
  loop.metric_pose = metric;
  loop.relative_pose = metric.pose;
  const LoopClosure message = toLoopMsg(loop, ros::Time(2.0), ros::Time(1.0), "odom", "camera");
  EXPECT_TRUE(message.verified);
  EXPECT_TRUE(message.has_relative_pose);
  EXPECT_TRUE(message.relative_pose_metric);
  EXPECT_EQ(message.inliers, 35u);
  EXPECT_DOUBLE_EQ(message.reprojection_error, 0.9);
  EXPECT_DOUBLE_EQ(message.relative_pose.pose.position.z, 0.45);
}

namespace {

// What rviz's marker display refuses or shows as an error (rviz/default_plugin/markers): a list
// marker without points, a line list with an odd count, colours that do not match the points,
// a zero scale, an unnormalised orientation, non-finite points, a text marker without text.
std::string rvizProblem(const visualization_msgs::Marker& marker) {
  using visualization_msgs::Marker;
  if (marker.action == Marker::DELETE || marker.action == Marker::DELETEALL) return "";
  if (marker.header.frame_id.empty()) return "no frame_id";
  const auto& q = marker.pose.orientation;
  if (std::abs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0) > 1e-3) {
    return "orientation not normalised";
  }
  if (marker.color.a <= 0.0f && marker.colors.empty()) return "invisible (alpha 0)";
  const bool list = marker.type == Marker::LINE_LIST || marker.type == Marker::LINE_STRIP ||
                    marker.type == Marker::SPHERE_LIST || marker.type == Marker::POINTS;
  if (list) {
    if (marker.points.empty()) return "Points should not be empty";
    if (marker.type == Marker::LINE_LIST && marker.points.size() % 2 != 0) return "odd line list";
    if (!marker.colors.empty() && marker.colors.size() != marker.points.size()) {
      return "colours and points differ in number";
    }
    for (const auto& p : marker.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return "point NaN";
    }
    if (marker.scale.x <= 0.0) return "scale.x 0";
  }
  if (marker.type == Marker::SPHERE_LIST && (marker.scale.y <= 0.0 || marker.scale.z <= 0.0)) {
    return "sphere scale 0";
  }
  if (marker.type == Marker::TEXT_VIEW_FACING && (marker.text.empty() || marker.scale.z <= 0.0)) {
    return "text marker without text or height";
  }
  return "";
}

void expectRvizAcceptsAll(const visualization_msgs::MarkerArray& array, const std::string& when) {
  for (const visualization_msgs::Marker& marker : array.markers) {
    EXPECT_EQ(rvizProblem(marker), "") << when << ": namespace " << marker.ns;
  }
}

}  // namespace

TEST(LoopMarkers, EveryMarkerTheNodePublishesIsOneRvizAccepts) {
  for (const bool show_rejected : {false, true}) {
    LoopMarkers markers("odom", 0.25, show_rejected);
    expectRvizAcceptsAll(markers.snapshot(ros::Time(1.0)), "nothing yet");
    markers.addKeyframe(planarPose(0.0, 0.0, 0.0));
    markers.addKeyframe(planarPose(1.0, 0.0, 0.0));
    expectRvizAcceptsAll(markers.snapshot(ros::Time(2.0)), "keyframes only");
    AcceptedLoop verified;
    verified.score = 0.3;
    verified.query_pose = planarPose(1.0, 0.0, 0.0);
    VerificationResult check;
    check.verdict = VerificationVerdict::kAccepted;
    verified.verification = check;
    markers.addLoop(verified);
    expectRvizAcceptsAll(markers.snapshot(ros::Time(3.0)), "a verified loop");
    AcceptedLoop unverified;
    unverified.score = 0.9;
    markers.addLoop(unverified);
    markers.addRejected(planarPose(1.0, 0.0, 0.0), planarPose(0.0, 0.0, 0.0));
    const visualization_msgs::MarkerArray all = markers.snapshot(ros::Time(4.0));
    expectRvizAcceptsAll(all, "every kind");
    // Verified loops are green at any score, unverified orange, rejected grey; a legend says so.
    std::map<std::string, visualization_msgs::Marker> by_namespace;
    for (const visualization_msgs::Marker& marker : all.markers) by_namespace[marker.ns] = marker;
    const auto& loop_colour = by_namespace["loops"].colors.at(0);
    EXPECT_GT(loop_colour.g, 2.0f * std::max(loop_colour.r, loop_colour.b)) << "green";
    const auto& orange = by_namespace["unverified_loops"].color;
    EXPECT_GT(orange.r, orange.g);
    EXPECT_GT(orange.g, orange.b);
    if (show_rejected) {
      EXPECT_EQ(by_namespace["rejected"].color.r, by_namespace["rejected"].color.g);
    }
    EXPECT_NE(by_namespace["legend"].text.find("green: verified"), std::string::npos);
    markers.changes(ros::Time(4.5));
    markers.clear();
    const visualization_msgs::MarkerArray cleared = markers.snapshot(ros::Time(5.0));
    expectRvizAcceptsAll(cleared, "after a reset");
    for (const visualization_msgs::Marker& marker : cleared.markers) {
      EXPECT_EQ(marker.action, visualization_msgs::Marker::DELETE) << marker.ns;
    }
    // A viewer that saw the old map is told to forget all of it.
    const visualization_msgs::MarkerArray reset = markers.changes(ros::Time(5.0));
    expectRvizAcceptsAll(reset, "the change after a reset");
    ASSERT_FALSE(reset.markers.empty());
    EXPECT_EQ(reset.markers.front().action, visualization_msgs::Marker::DELETEALL);
  }
}

// A keyframe's markers cost the same on a map of any size: only the chunk it changed goes out,
// while a viewer that connects later gets every chunk.
TEST(LoopMarkers, EachKeyframeSendsOnlyWhatItChanged) {
  LoopMarkers markers("odom", 0.25, true);
  const size_t keyframes = 2 * LoopMarkers::kChunkPoints + 10;
  VerificationResult check;
  check.verdict = VerificationVerdict::kAccepted;
  for (size_t i = 0; i < keyframes; ++i) {
    markers.addKeyframe(planarPose(0.1 * static_cast<double>(i), 0.0, 0.0));
    AcceptedLoop loop;
    loop.score = 0.5;
    loop.query_pose = planarPose(0.1 * static_cast<double>(i), 0.0, 0.0);
    loop.verification = check;
    markers.addLoop(loop);
    markers.changes(ros::Time(1.0));
  }
  markers.addKeyframe(planarPose(-1.0, 0.0, 0.0));
  const visualization_msgs::MarkerArray changed = markers.changes(ros::Time(2.0));
  expectRvizAcceptsAll(changed, "one keyframe's change");
  std::map<std::string, std::vector<visualization_msgs::Marker>> changed_by_namespace;
  for (const auto& marker : changed.markers) changed_by_namespace[marker.ns].push_back(marker);
  ASSERT_EQ(changed_by_namespace["keyframes"].size(), 1u);
  EXPECT_EQ(changed_by_namespace["keyframes"][0].id, 2);  // The third chunk, the one it joined.
  EXPECT_EQ(changed_by_namespace["keyframes"][0].points.size(), 11u);
  EXPECT_EQ(changed_by_namespace.count("loops"), 0u);  // No loop came: nothing re-sent.
  EXPECT_EQ(changed_by_namespace["legend"].size(), 1u);

  const visualization_msgs::MarkerArray all = markers.snapshot(ros::Time(3.0));
  expectRvizAcceptsAll(all, "a large map");
  size_t keyframe_points = 0;
  size_t loop_points = 0;
  for (const auto& marker : all.markers) {
    if (marker.ns == "keyframes") keyframe_points += marker.points.size();
    if (marker.ns == "loops") {
      loop_points += marker.points.size();
      EXPECT_EQ(marker.points.size() % 2, 0u) << "a line's two ends share a chunk";
    }
  }
  EXPECT_EQ(keyframe_points, keyframes + 1);
  EXPECT_EQ(loop_points, 2 * keyframes);
  EXPECT_TRUE(markers.changes(ros::Time(4.0)).markers.empty()) << "nothing new since";
}

TEST(LoopMarkers, VerifiedAndUnverifiedLoopsAreDrawnApart) {
  LoopMarkers markers("odom", 0.25, false);
  AcceptedLoop verified;
  verified.score = 0.5;
  verified.query_pose = planarPose(1.0, 2.0, 0.0);
  VerificationResult check;
  check.verdict = VerificationVerdict::kAmbiguous;  // Place confirmed, pose open.
  verified.verification = check;
  markers.addLoop(verified);
  AcceptedLoop unverified;
  unverified.query_pose = planarPose(5.0, 0.0, 0.0);
  markers.addLoop(unverified);
  const visualization_msgs::MarkerArray array = markers.snapshot(ros::Time(1.0));
  std::map<std::string, visualization_msgs::Marker> by_namespace;
  for (const visualization_msgs::Marker& marker : array.markers) by_namespace[marker.ns] = marker;
  ASSERT_EQ(by_namespace.count("loops"), 1u);
  ASSERT_EQ(by_namespace.count("unverified_loops"), 1u);
  ASSERT_EQ(by_namespace["loops"].points.size(), 2u);
  EXPECT_DOUBLE_EQ(by_namespace["loops"].points[0].x, 1.0);
  ASSERT_EQ(by_namespace["unverified_loops"].points.size(), 2u);
  EXPECT_DOUBLE_EQ(by_namespace["unverified_loops"].points[0].x, 5.0);
  EXPECT_LT(by_namespace["unverified_loops"].scale.x, by_namespace["loops"].scale.x);
}

TEST(RosConversions, CameraInfoGivesIntrinsicsAndAnUncalibratedOneIsInvalid) {
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.K = {500.0, 0.0, 319.5, 0.0, 510.0, 239.5, 0.0, 0.0, 1.0};
  const CameraIntrinsics intrinsics = fromCameraInfo(info);
  EXPECT_TRUE(intrinsics.valid());
  EXPECT_DOUBLE_EQ(intrinsics.fy, 510.0);
  EXPECT_DOUBLE_EQ(intrinsics.cx, 319.5);
  EXPECT_EQ(intrinsics.image_size, cv::Size(640, 480));
  EXPECT_FALSE(fromCameraInfo(sensor_msgs::CameraInfo{}).valid());  // K all zero.
}

TEST(RosConversions, CameraInfoCarriesTheLensModelAndRectifiedImagesUseP) {
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.K = {500.0, 0.0, 319.5, 0.0, 510.0, 239.5, 0.0, 0.0, 1.0};
  info.P = {480.0, 0.0, 321.0, 0.0, 0.0, 480.0, 241.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  info.distortion_model = "plumb_bob";
  info.D = {-0.3, 0.08, 0.001, 0.0, 0.0};
  const CameraIntrinsics raw = fromCameraInfo(info);
  EXPECT_TRUE(raw.valid()) << raw.problem();
  EXPECT_EQ(raw.distortion, LensDistortion::kPlumbBob);
  EXPECT_EQ(raw.coefficients, info.D);
  EXPECT_TRUE(raw.distorted());
  EXPECT_DOUBLE_EQ(raw.fx, 500.0);
  // image_rect: P's camera, nothing left to correct.
  const CameraIntrinsics rectified = fromCameraInfo(info, /*rectified=*/true);
  EXPECT_TRUE(rectified.valid());
  EXPECT_FALSE(rectified.distorted());
  EXPECT_DOUBLE_EQ(rectified.fx, 480.0);
  EXPECT_DOUBLE_EQ(rectified.cx, 321.0);
  EXPECT_DOUBLE_EQ(rectified.cy, 241.0);
  // A model we cannot apply makes the calibration unusable, said by its own cause.
  info.distortion_model = "kannala_brandt";
  const CameraIntrinsics unknown = fromCameraInfo(info);
  ASSERT_TRUE(unknown.check());
  EXPECT_EQ(unknown.check()->cause, "distortion_model");
  // Zeros under any name (simulators, uncalibrated drivers): a pinhole.
  info.D.assign(5, 0.0);
  EXPECT_TRUE(fromCameraInfo(info).valid());
  EXPECT_FALSE(fromCameraInfo(info).distorted());
}

TEST(RosConversions, CandidatesCarryVerdictConstants) {
  KeyframeResult result;
  result.keyframe_id = 9;
  result.query_status = QueryStatus::kSearched;
  CandidateReport report;
  report.match_id = 2;
  report.verdict = CandidateVerdict::kAwaitingConsistency;
  result.candidates.push_back(report);
  report.verdict = CandidateVerdict::kGeometryRejected;
  report.detail = "too few geometric inliers";
  report.inliers = 12;
  result.candidates.push_back(report);
  const LoopCandidateArray message =
      toCandidatesMsg(result, 7, ros::Time(1.0), "odom", [](uint64_t id) { return ros::Time(id); });
  EXPECT_EQ(message.query_status, "searched");
  EXPECT_EQ(message.map_id, 7u);
  ASSERT_EQ(message.candidates.size(), 2u);
  EXPECT_EQ(message.candidates[0].verdict, LoopCandidate::AWAITING_CONSISTENCY);
  EXPECT_EQ(message.candidates[0].reason, "awaiting_consistency");
  EXPECT_EQ(message.candidates[0].match_stamp, ros::Time(2.0));
  EXPECT_EQ(message.candidates[1].verdict, LoopCandidate::GEOMETRY_REJECTED);
  EXPECT_EQ(message.candidates[1].reason, "geometry_rejected: too few geometric inliers");
  EXPECT_EQ(message.candidates[1].inliers, 12u);
}

TEST(RosConversions, OdometryRejectionsCarryTheirNumbersInTheReason) {
  KeyframeResult result;
  CandidateReport report;
  report.match_id = 4;
  report.verdict = CandidateVerdict::kOdometryRejected;
  report.detail = "odometry: needs a 26.0 m correction, drift allows 4.0 m";
  result.candidates.push_back(report);
  const LoopCandidateArray message =
      toCandidatesMsg(result, 7, ros::Time(1.0), "odom", [](uint64_t id) { return ros::Time(id); });
  ASSERT_EQ(message.candidates.size(), 1u);
  EXPECT_EQ(message.candidates[0].verdict, LoopCandidate::ODOMETRY_REJECTED);
  EXPECT_EQ(message.candidates[0].reason,
            "odometry_rejected: odometry: needs a 26.0 m correction, drift allows 4.0 m");
}

TEST(RosConversions, EveryKeptFuzzInputIsRefusedOrConverted) {
  const std::vector<KeptFuzzInput> inputs = keptFuzzInputs("fuzz_image_message");
  for (const KeptFuzzInput& input : inputs) {
    SCOPED_TRACE(input.path.string());
    const sensor_msgs::Image image = fuzz::imageFromBytes(input.bytes.data(), input.bytes.size());
    if (!checkImageMessage(image)) {
      EXPECT_EQ(toGrey(image).type(), CV_8UC1);
    }
    std::string error;
    const cv::Mat depth = toDepth(image, &error);
    EXPECT_NE(depth.empty(), error.empty());  // A depth image or a reason, never both.
  }
  EXPECT_GE(inputs.size(), 5u);
}

TEST(RosParameterSource, IntegersAreStrictAndNumbersTakeIntegers) {
  XmlRpc::XmlRpcValue two_and_a_half(2.5);
  XmlRpc::XmlRpcValue eight(8);
  XmlRpc::XmlRpcValue word("fast");
  XmlRpc::XmlRpcValue yes(true);
  int integer = 0;
  EXPECT_EQ(fromXmlRpc(two_and_a_half, &integer), ParameterLookup::kWrongType)
      << "worker_queue_size: 2.5 must not become 2";
  EXPECT_EQ(fromXmlRpc(eight, &integer), ParameterLookup::kFound);
  EXPECT_EQ(integer, 8);
  double number = 0.0;
  EXPECT_EQ(fromXmlRpc(eight, &number), ParameterLookup::kFound);
  EXPECT_EQ(number, 8.0);
  EXPECT_EQ(fromXmlRpc(word, &number), ParameterLookup::kWrongType);
  bool flag = false;
  EXPECT_EQ(fromXmlRpc(eight, &flag), ParameterLookup::kWrongType);
  EXPECT_EQ(fromXmlRpc(yes, &flag), ParameterLookup::kFound);
  std::string text;
  EXPECT_EQ(fromXmlRpc(eight, &text), ParameterLookup::kWrongType);
  EXPECT_EQ(fromXmlRpc(word, &text), ParameterLookup::kFound);
}

// (map_id, id) names a keyframe: every message that carries an id carries its map.
TEST(RosConversions, KeyframesAndLoopsCarryTheirMap) {
  const Keyframe keyframe =
      toKeyframeMsg(12, 1, 0xFEDCBA9876543210ull, ros::Time(3.0), Pose(), "odom");
  EXPECT_EQ(keyframe.map_id, 0xFEDCBA9876543210ull);
  EXPECT_EQ(keyframe.id, 12u);
  EXPECT_EQ(keyframe.session, 1u);
  AcceptedLoop loop;
  loop.map_id = 0xFEDCBA9876543210ull;
  loop.query_id = 12;
  loop.match_id = 3;
  const LoopClosure message = toLoopMsg(loop, ros::Time(3.0), ros::Time(1.0), "odom", "camera");
  EXPECT_EQ(message.map_id, 0xFEDCBA9876543210ull);
  EXPECT_EQ(message.match_map_id, message.map_id);  // A detector's loops stay in its map.
  EXPECT_EQ(message.match_id, 3u);
}
