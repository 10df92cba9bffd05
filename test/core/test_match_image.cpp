#include <gtest/gtest.h>

#include "landmark_loop_closure/core/match_image.h"

using namespace landmark_loop_closure;

namespace {

constexpr int kBand = 64;  // The verdict band above the images.

MatchView blackPair() {
  MatchView view;
  view.query = cv::Mat(120, 160, CV_8UC1, cv::Scalar(0));
  view.match = view.query;
  return view;
}

}  // namespace

TEST(MatchImage, PutsBothImagesSideBySideUnderTheVerdictBand) {
  MatchView view;
  view.query = cv::Mat(120, 160, CV_8UC1, cv::Scalar(50));
  view.match = cv::Mat(240, 320, CV_8UC3, cv::Scalar(200, 200, 200));
  view.verdict = MatchView::Verdict::kAccepted;
  view.headline = "LOOP  keyframe 10 -> 2";
  const cv::Mat picture = renderMatchImage(view, 240);
  ASSERT_EQ(picture.type(), CV_8UC3);
  EXPECT_EQ(picture.cols, 320 + 320);
  EXPECT_EQ(picture.rows, kBand + 240);
  EXPECT_EQ(picture.at<cv::Vec3b>(kBand + 100, 100), cv::Vec3b(50, 50, 50));
  EXPECT_EQ(picture.at<cv::Vec3b>(kBand + 100, 500), cv::Vec3b(200, 200, 200));
}

TEST(MatchImage, TheBandsColourSaysTheVerdict) {
  MatchView view = blackPair();
  const auto bandAt = [&](MatchView::Verdict verdict) {
    view.verdict = verdict;
    return renderMatchImage(view, 240).at<cv::Vec3b>(2, 630);  // Past the text.
  };
  const cv::Vec3b accepted = bandAt(MatchView::Verdict::kAccepted);
  const cv::Vec3b candidate = bandAt(MatchView::Verdict::kCandidate);
  const cv::Vec3b rejected = bandAt(MatchView::Verdict::kRejected);
  EXPECT_GT(accepted[1], accepted[2]) << "accepted is green";
  EXPECT_GT(candidate[2], candidate[0]) << "a candidate is orange";
  EXPECT_EQ(rejected[0], rejected[2]) << "rejected is grey";
  EXPECT_NE(accepted, candidate);
}

TEST(MatchImage, MissingMatchIsDrawnAsAPlaceholder) {
  MatchView view;
  view.query = cv::Mat(120, 160, CV_8UC1, cv::Scalar(50));
  const cv::Mat picture = renderMatchImage(view, 120);
  EXPECT_EQ(picture.rows, kBand + 120);
  EXPECT_EQ(picture.cols, 160 + 160);
}

TEST(MatchImage, DrawsAtMostTheStrongestLandmarkPairsInOneColourPerPair) {
  MatchView view = blackPair();
  view.landmark_pairs = {{cv::Rect2f(10, 10, 40, 30), cv::Rect2f(100, 50, 40, 30)}};
  // More pairs than are drawn, each at its own place further down, all inside the 120 rows.
  for (int i = 1; i < 9; ++i) {
    view.landmark_pairs.push_back(
        {cv::Rect2f(2, 10.0f * i + 30, 4, 4), cv::Rect2f(2, 10.0f * i + 30, 4, 4)});
  }
  const cv::Mat picture = renderMatchImage(view, 240);
  // Height 240 doubles the 160x120 images: the first query box's corner lands at (20, 20), its
  // match box's at (320 + 200, 100), both below the band.
  const cv::Vec3b left = picture.at<cv::Vec3b>(kBand + 20, 20);
  const cv::Vec3b right = picture.at<cv::Vec3b>(kBand + 100, 320 + 200);
  EXPECT_NE(left, cv::Vec3b(0, 0, 0));
  EXPECT_EQ(left, right);
  const auto drawn = [&](int pair) {
    return picture.at<cv::Vec3b>(kBand + 2 * (10 * pair + 30), 4) != cv::Vec3b(0, 0, 0);
  };
  for (int pair = 1; pair < static_cast<int>(MatchView::kMaxLandmarkPairs); ++pair) {
    EXPECT_TRUE(drawn(pair)) << pair;
  }
  for (int pair = MatchView::kMaxLandmarkPairs; pair < 9; ++pair) {
    EXPECT_FALSE(drawn(pair)) << "pair " << pair << " is past the strongest few";
  }
}

TEST(MatchImage, DrawsGeometricInliersAsJoinedDots) {
  MatchView view = blackPair();
  view.inliers = {{cv::Point2f(30, 40), cv::Point2f(50, 40)}};
  const cv::Mat picture = renderMatchImage(view, 240);
  // Doubled: the query dot at (60, 80), the match dot at (320 + 100, 80), the line between.
  EXPECT_EQ(picture.at<cv::Vec3b>(kBand + 80, 60), cv::Vec3b(60, 220, 60));
  EXPECT_EQ(picture.at<cv::Vec3b>(kBand + 80, 420), cv::Vec3b(60, 220, 60));
  EXPECT_NE(picture.at<cv::Vec3b>(kBand + 80, 240), cv::Vec3b(0, 0, 0));
}
