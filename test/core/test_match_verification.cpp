// lcd_evaluate --appearance-check: single-image matches checked as the node checks a loop.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/eval/match_verification.h"

namespace landmark_loop_closure {
namespace eval {
namespace {

// Feature maps straight from the thumbnail's pixels: 16x12 cells of 10x10 px, each cell's
// channels its first 32 pixels. Pictures of random texture then give distinctive cells, as a
// network's maps of real places do.
class PixelCells : public DescriptorExtractor {
 public:
  explicit PixelCells(bool has_maps) : has_maps_(has_maps) {}
  std::string name() const override { return "pixel_cells"; }
  int globalDimension() const override { return 1; }
  ImageDescriptor describe(const cv::Mat&) const override { return {}; }
  FeatureMaps appearanceMaps(const cv::Mat& image) const override {
    if (!has_maps_) return {};
    cv::Mat grey;
    if (image.channels() == 1) {
      grey = image;
    } else {
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    }
    FeatureMaps maps;
    maps.channels = 32;
    maps.height = grey.rows / 10;
    maps.width = grey.cols / 10;
    maps.values.resize(static_cast<size_t>(maps.channels) * maps.height * maps.width);
    for (int c = 0; c < maps.channels; ++c) {
      for (int y = 0; y < maps.height; ++y) {
        for (int x = 0; x < maps.width; ++x) {
          maps.values[(static_cast<size_t>(c) * maps.height + y) * maps.width + x] =
              grey.at<uint8_t>(y * 10 + c / 10, x * 10 + c % 10);
        }
      }
    }
    return maps;
  }

 private:
  bool has_maps_;
};

// Place i's texture, wider than a picture of it: random blocks (smooth enough to survive the
// thumbnail) under random shapes whose corners ORB finds.
cv::Mat texture(size_t i) {
  cv::Mat noise(60, 90, CV_8UC3);
  cv::RNG random(1000 + i);
  random.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat image;
  cv::resize(noise, image, cv::Size(360, 240), 0, 0, cv::INTER_NEAREST);
  for (int shape = 0; shape < 200; ++shape) {
    const cv::Point corner(random.uniform(0, image.cols), random.uniform(0, image.rows));
    const cv::Scalar colour(random.uniform(0, 256), random.uniform(0, 256), random.uniform(0, 256));
    if (shape % 2 == 0) {
      cv::circle(image, corner, random.uniform(3, 15), colour, cv::FILLED);
    } else {
      const cv::Size size(random.uniform(4, 24), random.uniform(4, 24));
      cv::rectangle(image, cv::Rect(corner, size), colour, cv::FILLED);
    }
  }
  return image;
}

// Place i seen by a 320x240 camera.
cv::Mat place(size_t i) { return texture(i).colRange(20, 340).clone(); }

// Place i seen from 0.2 m to the right, its left half 2 m away and its right half 4 m (fx 160):
// the halves shift by 16 and 8 px, a two-view geometry with parallax.
cv::Mat placeFromTheRight(size_t i) {
  const cv::Mat wide = texture(i);
  cv::Mat view(240, 320, CV_8UC3);
  wide.colRange(36, 196).copyTo(view.colRange(0, 160));
  wide.colRange(188, 348).copyTo(view.colRange(160, 320));
  return view;
}

QueryOutcome outcome(size_t query, long match, double score, bool correct) {
  QueryOutcome result;
  result.query = query;
  result.match = match;
  result.score = score;
  result.correct = correct;
  result.has_truth = true;
  return result;
}

// Queries 0-2 see places 0-2; query 1's best match is place 7, wrong, and scores highest.
std::vector<QueryOutcome> outcomesWithOneConfidentWrongMatch() {
  return {outcome(0, 0, 0.5, true), outcome(1, 7, 0.9, false), outcome(2, 2, 0.4, true),
          outcome(3, -1, 0.0, false)};
}

TEST(MatchVerification, AWrongMatchTheCheckRefusesRanksBelowTheRightOnes) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  const Metrics before = computeMetrics(outcomes);
  EXPECT_DOUBLE_EQ(before.vprbench.recall_at_100_precision, 0.0);

  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, place, place, PixelCells(true), MatchChecks());
  EXPECT_EQ(summary.checked, 3u);
  EXPECT_EQ(summary.refused, 1u);
  EXPECT_EQ(summary.refused_correct, 0u);
  EXPECT_EQ(summary.confirmed_correct, 2u);
  EXPECT_EQ(summary.confirmed_wrong, 0u);
  EXPECT_FALSE(outcomes[0].refused);
  EXPECT_TRUE(outcomes[1].refused);
  EXPECT_GE(outcomes[0].appearance_inliers, AppearanceCheckOptions().min_inliers);
  EXPECT_LT(outcomes[1].appearance_inliers, AppearanceCheckOptions().min_inliers);
  EXPECT_EQ(outcomes[3].appearance_inliers, -1);  // Matched nothing: nothing to check.
  EXPECT_LT(outcomes[1].score, outcomes[2].score);
  // The confirmed keep their scores; every match stays a match.
  EXPECT_DOUBLE_EQ(outcomes[0].score, 0.5);
  EXPECT_DOUBLE_EQ(outcomes[2].score, 0.4);
  EXPECT_EQ(outcomes[1].match, 7);

  const Metrics after = computeMetrics(outcomes);
  EXPECT_DOUBLE_EQ(after.vprbench.recall_at_100_precision, 1.0);
  EXPECT_DOUBLE_EQ(after.recall_at_1, before.recall_at_1);
}

TEST(MatchVerification, RefusedMatchesKeepTheirOrderAmongThemselves) {
  std::vector<QueryOutcome> outcomes = {outcome(0, 5, 0.9, false), outcome(1, 6, 0.8, false),
                                        outcome(2, 2, 0.1, true)};
  verifyMatches(&outcomes, place, place, PixelCells(true), MatchChecks());
  ASSERT_TRUE(outcomes[0].refused && outcomes[1].refused);
  EXPECT_GT(outcomes[0].score, outcomes[1].score);
  EXPECT_LT(outcomes[0].score, outcomes[2].score);
}

TEST(MatchVerification, WithoutFeatureMapsNothingIsCheckedOrMoved) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, place, place, PixelCells(false), MatchChecks());
  EXPECT_EQ(summary.checked, 0u);
  EXPECT_EQ(summary.unverifiable, 3u);
  EXPECT_DOUBLE_EQ(outcomes[1].score, 0.9);
  EXPECT_FALSE(outcomes[1].refused);
  EXPECT_EQ(outcomes[1].appearance_inliers, -1);
}

TEST(MatchVerification, AnImageThatDoesNotLoadLeavesItsMatchAsItIs) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  const auto missing_query_one = [](size_t i) { return i == 1 ? cv::Mat() : place(i); };
  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, missing_query_one, place, PixelCells(true), MatchChecks());
  EXPECT_EQ(summary.checked, 2u);
  EXPECT_EQ(summary.unverifiable, 1u);
  EXPECT_FALSE(outcomes[1].refused);
  EXPECT_DOUBLE_EQ(outcomes[1].score, 0.9);
}

// The camera of place(): 320x240 px, 90 degrees across.
MatchChecks withIntrinsics() {
  MatchChecks checks;
  checks.intrinsics.fx = 160.0;
  checks.intrinsics.fy = 160.0;
  checks.intrinsics.cx = 160.0;
  checks.intrinsics.cy = 120.0;
  checks.intrinsics.image_size = cv::Size(320, 240);
  return checks;
}

TEST(MatchVerification, WithIntrinsicsOrbConfirmsAPlaceWithoutCellsAndRefusesAWrongOne) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  const MatchChecks checks = withIntrinsics();
  ASSERT_TRUE(checks.runsGeometry());
  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, place, placeFromTheRight, PixelCells(false), checks);
  EXPECT_EQ(summary.checked, 3u);
  EXPECT_EQ(summary.unverifiable, 0u);
  EXPECT_EQ(summary.confirmed_correct, 2u);
  EXPECT_EQ(summary.confirmed_by_geometry, 2u);
  EXPECT_EQ(summary.confirmed_wrong, 0u);
  // ORB refuses the wrong place and no cells can confirm it: refused, as the node refuses it.
  EXPECT_TRUE(outcomes[1].refused);
  EXPECT_LT(outcomes[1].geometry_inliers, checks.geometry.min_inliers);
  EXPECT_GE(outcomes[0].geometry_inliers, checks.geometry.min_inliers);
  EXPECT_EQ(outcomes[0].appearance_inliers, -1);  // Confirmed by ORB: no appearance check.
  EXPECT_LT(outcomes[1].score, outcomes[2].score);
}

TEST(MatchVerification, WhereOrbCannotConfirmTheAppearanceCheckDecides) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  MatchChecks checks = withIntrinsics();
  checks.geometry.min_inliers = 100000;  // More than any image has keypoints.
  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, place, place, PixelCells(true), checks);
  EXPECT_EQ(summary.checked, 3u);
  EXPECT_EQ(summary.confirmed_by_geometry, 0u);
  EXPECT_EQ(summary.confirmed_correct, 2u);
  EXPECT_EQ(summary.refused, 1u);
  EXPECT_TRUE(outcomes[1].refused);
  EXPECT_GE(outcomes[0].appearance_inliers, AppearanceCheckOptions().min_inliers);
}

TEST(MatchVerification, WithTheAppearanceCheckOffWhatOrbCannotConfirmIsRefused) {
  std::vector<QueryOutcome> outcomes = outcomesWithOneConfidentWrongMatch();
  MatchChecks checks = withIntrinsics();
  checks.geometry.min_inliers = 100000;  // ORB confirms nothing.
  checks.appearance.enabled = false;     // The cells would confirm the right places.
  const MatchVerificationSummary summary =
      verifyMatches(&outcomes, place, place, PixelCells(true), checks);
  EXPECT_EQ(summary.checked, 3u);
  EXPECT_EQ(summary.refused, 3u);
  EXPECT_EQ(summary.confirmed_correct, 0u);
  EXPECT_EQ(outcomes[0].appearance_inliers, -1);
}

}  // namespace
}  // namespace eval
}  // namespace landmark_loop_closure
