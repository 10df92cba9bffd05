#include <gtest/gtest.h>

#include "landmark_loop_closure/core/match_image.h"

using namespace landmark_loop_closure;

TEST(MatchImage, PutsBothImagesSideBySideAtTheRequestedHeight) {
  const cv::Mat query(120, 160, CV_8UC1, cv::Scalar(50));
  const cv::Mat match(240, 320, CV_8UC3, cv::Scalar(200, 200, 200));
  const cv::Mat picture = renderMatchImage(query, match, "keyframe 10 vs 2", true, 240);
  ASSERT_EQ(picture.type(), CV_8UC3);
  EXPECT_EQ(picture.cols, 320 + 320);
  EXPECT_GT(picture.rows, 240);  // Caption line below.
  EXPECT_EQ(picture.at<cv::Vec3b>(100, 100), cv::Vec3b(50, 50, 50));
  EXPECT_EQ(picture.at<cv::Vec3b>(100, 500), cv::Vec3b(200, 200, 200));
}

TEST(MatchImage, MissingMatchIsDrawnAsAPlaceholder) {
  const cv::Mat query(120, 160, CV_8UC1, cv::Scalar(50));
  const cv::Mat picture = renderMatchImage(query, cv::Mat(), "no thumbnail", false, 120);
  EXPECT_EQ(picture.rows > 120, true);
  EXPECT_EQ(picture.cols, 160 + 160);
}

TEST(MatchImage, DrawsMatchedLandmarksInTheSameColourOnBothSides) {
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(0));
  const std::vector<std::pair<cv::Rect2f, cv::Rect2f>> pairs = {
      {cv::Rect2f(10, 10, 40, 30), cv::Rect2f(100, 50, 40, 30)}};
  const cv::Mat picture = renderMatchImage(grey, grey, "pairs", true, 240, pairs);
  // Height 240 doubles the 160x120 images: the query box's corner lands at (20, 20), the match
  // box's at (320 + 200, 100).
  const cv::Vec3b left = picture.at<cv::Vec3b>(20, 20);
  const cv::Vec3b right = picture.at<cv::Vec3b>(100, 320 + 200);
  EXPECT_NE(left, cv::Vec3b(0, 0, 0));
  EXPECT_EQ(left, right);
}

TEST(MatchImage, DrawsGeometricInliersAsJoinedDots) {
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(0));
  const std::vector<std::pair<cv::Point2f, cv::Point2f>> inliers = {
      {cv::Point2f(30, 40), cv::Point2f(50, 40)}};
  const cv::Mat picture = renderMatchImage(grey, grey, "inliers", true, 240, {}, inliers);
  // Doubled: the query dot at (60, 80), the match dot at (320 + 100, 80), the line between.
  EXPECT_EQ(picture.at<cv::Vec3b>(80, 60), cv::Vec3b(60, 220, 60));
  EXPECT_EQ(picture.at<cv::Vec3b>(80, 420), cv::Vec3b(60, 220, 60));
  EXPECT_NE(picture.at<cv::Vec3b>(80, 240), cv::Vec3b(0, 0, 0));
}
