#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/input_error.h"

using namespace landmark_loop_closure;

TEST(CheckImage, AcceptsSupportedTypes) {
  const InputLimits limits;
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    EXPECT_FALSE(checkImage(320, 240, type, limits)) << cv::typeToString(type);
  }
}

TEST(CheckImage, RefusesEachKindOfBadImage) {
  const InputLimits limits;
  EXPECT_EQ(checkImage(0, 0, CV_8UC1, limits)->code, InputErrorCode::kEmptyImage);
  EXPECT_EQ(checkImage(320, 0, CV_8UC1, limits)->code, InputErrorCode::kEmptyImage);
  EXPECT_EQ(checkImage(8, 240, CV_8UC1, limits)->code, InputErrorCode::kImageTooSmall);
  EXPECT_EQ(checkImage(20000, 20000, CV_8UC1, limits)->code, InputErrorCode::kImageTooLarge);
  EXPECT_EQ(checkImage(320, 240, CV_32FC1, limits)->code, InputErrorCode::kUnsupportedImageType);
  EXPECT_EQ(checkImage(320, 240, CV_8UC2, limits)->code, InputErrorCode::kUnsupportedImageType);
}

TEST(CheckImage, MessageNamesTheValues) {
  const auto error = checkImage(8, 6, CV_8UC1, InputLimits{});
  ASSERT_TRUE(error);
  EXPECT_NE(error->message.find("8x6"), std::string::npos) << error->message;
}

TEST(CheckPose, RefusesNonFiniteValues) {
  Pose pose;
  pose.position.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(checkPose(pose, InputLimits{})->code, InputErrorCode::kNonFinitePose);
  pose = Pose{};
  pose.orientation.w() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(checkPose(pose, InputLimits{})->code, InputErrorCode::kNonFinitePose);
}

TEST(CheckPose, RefusesAPositionNoOdometryReaches) {
  Pose pose;
  pose.position.z() = -5e173;  // Finite, but its distance to any other pose overflows.
  const auto error = checkPose(pose, InputLimits{});
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kPoseOutOfRange);
  EXPECT_NE(error->message.find("-5e+173"), std::string::npos) << error->message;
  pose.position = Eigen::Vector3d(-1e9, 1e9, 0.0);  // The limit itself is accepted.
  EXPECT_FALSE(checkPose(pose, InputLimits{}));
}

TEST(CheckPose, RefusesNonUnitQuaternionButToleratesRounding) {
  Pose pose;
  pose.orientation = Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(checkPose(pose, InputLimits{})->code, InputErrorCode::kNonUnitQuaternion);
  pose.orientation = Eigen::Quaterniond(0.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(checkPose(pose, InputLimits{})->code, InputErrorCode::kNonUnitQuaternion);
  pose.orientation = Eigen::Quaterniond(1.001, 0.0, 0.0, 0.0);
  EXPECT_FALSE(checkPose(pose, InputLimits{}));
  EXPECT_NEAR(normalisedPose(pose).orientation.norm(), 1.0, 1e-12);
}

TEST(CheckTexture, RefusesUniformImagesOfEveryKind) {
  const InputLimits limits;
  EXPECT_EQ(checkTexture(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), limits)->code,
            InputErrorCode::kNoTexture);
  EXPECT_TRUE(checkTexture(cv::Mat(480, 640, CV_8UC3, cv::Scalar(255, 255, 255)), limits));
  EXPECT_TRUE(checkTexture(cv::Mat(480, 640, CV_16UC1, cv::Scalar(30000)), limits));
  // Sensor noise of one grey level is still no texture.
  cv::Mat noisy(480, 640, CV_8UC1);
  cv::randn(noisy, 20, 1);
  const auto error = checkTexture(noisy, limits);
  ASSERT_TRUE(error);
  EXPECT_NE(error->message.find("advanced/input/min_image_contrast"), std::string::npos)
      << error->message;
}

TEST(CheckTexture, RefusesADarkFrameWhateverALampOrALogoAddsToIt) {
  // A tunnel: black, with a lamp and a broadcaster's logo covering 4 % of the frame. Their
  // brightness alone gives a standard deviation of ~40 grey levels; the middle 90 % spreads 0.
  cv::Mat tunnel(480, 640, CV_8UC3, cv::Scalar(6, 6, 6));
  tunnel(cv::Rect(300, 200, 40, 200)).setTo(cv::Scalar(255, 255, 255));
  tunnel(cv::Rect(560, 10, 56, 20)).setTo(cv::Scalar(200, 200, 200));
  cv::Scalar mean, deviation;
  cv::meanStdDev(tunnel, mean, deviation);
  ASSERT_GT(deviation[0], 30.0);
  const auto error = checkTexture(tunnel, InputLimits{});
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, InputErrorCode::kNoTexture);
  EXPECT_NE(error->message.find("spread 0 between the 5th and 95th percentiles"), std::string::npos)
      << error->message;
  // The same frame lit up (the tunnel's walls show, 20-60 grey levels) has a place to recognise.
  cv::Mat walls(480, 640, CV_8UC3);
  cv::randu(walls, 20, 60);
  walls(cv::Rect(300, 200, 40, 200)).setTo(cv::Scalar(255, 255, 255));
  EXPECT_FALSE(checkTexture(walls, InputLimits{}));
}

TEST(CheckTexture, MeasuresSixteenBitImagesOnTheEightBitScale) {
  cv::Mat dim(120, 160, CV_16UC1);
  cv::randu(dim, 0, 10 * 257);  // Spreads ~9 levels of 255: no texture.
  EXPECT_TRUE(checkTexture(dim, InputLimits{}));
  cv::Mat textured(120, 160, CV_16UC1);
  cv::randu(textured, 0, 40 * 257);  // ~36 levels.
  EXPECT_FALSE(checkTexture(textured, InputLimits{}));
}

TEST(CheckTexture, AcceptsTexturedImagesAndCanBeTurnedOff) {
  cv::Mat textured(480, 640, CV_8UC1);
  cv::randu(textured, 0, 256);
  EXPECT_FALSE(checkTexture(textured, InputLimits{}));
  cv::Mat wide(480, 640, CV_16UC1);
  cv::randu(wide, 0, 65535);
  EXPECT_FALSE(checkTexture(wide, InputLimits{}));
  InputLimits off;
  off.min_image_contrast = 0.0;
  EXPECT_FALSE(checkTexture(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), off));
}

TEST(InputErrorCode, EveryCodeHasAName) {
  for (int code = 0; code <= static_cast<int>(InputErrorCode::kMalformedImage); ++code) {
    EXPECT_STRNE(toString(static_cast<InputErrorCode>(code)), "unknown");
  }
}

TEST(KindThrottle, EachKindHasItsOwnSilence) {
  KindThrottle throttle(10.0);
  EXPECT_TRUE(throttle.allow("encoding", 100.0));
  EXPECT_FALSE(throttle.allow("encoding", 101.0));
  EXPECT_TRUE(throttle.allow("size", 102.0)) << "a second kind is not hidden by the first";
  EXPECT_FALSE(throttle.allow("size", 111.0));
  EXPECT_TRUE(throttle.allow("encoding", 110.0));
  EXPECT_TRUE(throttle.allow("size", 112.5));
}
