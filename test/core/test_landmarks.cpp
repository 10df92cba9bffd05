#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/descriptors/landmarks.h"

using namespace landmark_loop_closure;

namespace {

FeatureMaps zeros(int channels, int height, int width) {
  FeatureMaps maps;
  maps.channels = channels;
  maps.height = height;
  maps.width = width;
  maps.values.assign(static_cast<size_t>(channels) * height * width, 0.0f);
  return maps;
}

void set(FeatureMaps* maps, int c, int y, int x, float value) {
  maps->values[(static_cast<size_t>(c) * maps->height + y) * maps->width + x] = value;
}

void fill(FeatureMaps* maps, int c, cv::Rect cells, float value) {
  for (int y = cells.y; y < cells.y + cells.height; ++y) {
    for (int x = cells.x; x < cells.x + cells.width; ++x) set(maps, c, y, x, value);
  }
}

}  // namespace

TEST(LandmarkProposals, ComponentsEnergiesBoxesAndOrder) {
  FeatureMaps maps = zeros(2, 10, 20);
  fill(&maps, 0, cv::Rect(1, 1, 3, 3), 2.0f);   // A: energy 2.
  fill(&maps, 0, cv::Rect(10, 2, 4, 2), 5.0f);  // B: energy 5.
  set(&maps, 0, 8, 18, 9.0f);                   // A single cell: too small.
  // C, in channel 1: a diagonal, one component only under 8-connectivity; values 1 and 5 -> 3.
  set(&maps, 1, 5, 5, 1.0f);
  set(&maps, 1, 6, 6, 5.0f);
  set(&maps, 1, 7, 7, 3.0f);
  const std::vector<LandmarkProposal> proposals =
      proposeLandmarks(maps, cv::Size(200, 100), LandmarkProposalOptions{});
  ASSERT_EQ(proposals.size(), 3u);
  EXPECT_DOUBLE_EQ(proposals[0].energy, 5.0);
  EXPECT_EQ(proposals[0].cells, cv::Rect(10, 2, 4, 2));
  EXPECT_EQ(proposals[0].box, cv::Rect2f(100, 20, 40, 20));  // 10 px per cell.
  EXPECT_DOUBLE_EQ(proposals[1].energy, 3.0);
  EXPECT_EQ(proposals[1].channel, 1);
  EXPECT_EQ(proposals[1].cells, cv::Rect(5, 5, 3, 3));
  EXPECT_DOUBLE_EQ(proposals[2].energy, 2.0);
  EXPECT_EQ(proposals[2].cells, cv::Rect(1, 1, 3, 3));
}

TEST(LandmarkProposals, NegativeAndZeroActivationsAreBackground) {
  FeatureMaps maps = zeros(1, 6, 6);
  fill(&maps, 0, cv::Rect(0, 0, 6, 6), -1.0f);
  fill(&maps, 0, cv::Rect(2, 2, 2, 2), 1.0f);
  const auto proposals = proposeLandmarks(maps, cv::Size(6, 6), LandmarkProposalOptions{});
  ASSERT_EQ(proposals.size(), 1u);
  EXPECT_EQ(proposals[0].cells, cv::Rect(2, 2, 2, 2));
}

TEST(LandmarkProposals, SuppressesDuplicatesAndKeepsAtMostM) {
  FeatureMaps maps = zeros(3, 10, 10);
  fill(&maps, 0, cv::Rect(1, 1, 4, 4), 1.0f);
  fill(&maps, 1, cv::Rect(1, 1, 4, 4), 2.0f);  // Same box, stronger: it stays, channel 0's goes.
  fill(&maps, 2, cv::Rect(6, 6, 3, 3), 0.5f);
  LandmarkProposalOptions options;
  const auto proposals = proposeLandmarks(maps, cv::Size(10, 10), options);
  ASSERT_EQ(proposals.size(), 2u);
  EXPECT_EQ(proposals[0].channel, 1);
  EXPECT_EQ(proposals[1].channel, 2);
  options.max_landmarks = 1;
  EXPECT_EQ(proposeLandmarks(maps, cv::Size(10, 10), options).size(), 1u);
}

TEST(LandmarkProposals, EmptyMapsGiveNothing) {
  EXPECT_TRUE(proposeLandmarks(FeatureMaps{}, cv::Size(10, 10), LandmarkProposalOptions{}).empty());
  EXPECT_TRUE(
      proposeLandmarks(zeros(4, 5, 5), cv::Size(10, 10), LandmarkProposalOptions{}).empty());
}

TEST(LandmarkDescriptors, CropFromTheSharedMapIsTranslationInvariant) {
  FeatureMaps maps = zeros(2, 8, 24);
  // The same 4x4 pattern at two places.
  for (int x0 : {2, 14}) {
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 4; ++x) {
        set(&maps, 0, 2 + y, x0 + x, static_cast<float>(x + 1));
        set(&maps, 1, 2 + y, x0 + x, static_cast<float>(y + 1));
      }
    }
  }
  const cv::Size image(240, 80);  // 10 px per cell.
  const std::vector<cv::Rect2f> boxes = {{20, 20, 40, 40}, {140, 20, 40, 40}, {80, 0, 40, 80}};
  const cv::Mat features = describeLandmarks(maps, image, boxes, 4);
  ASSERT_EQ(features.rows, 3);
  ASSERT_EQ(features.cols, 2 * 4 * 4);
  EXPECT_NEAR(cv::norm(features.row(0) - features.row(1)), 0.0, 1e-5);
  EXPECT_NEAR(cv::norm(features.row(0)), 1.0, 1e-5);
  // Grid cells sample the cells under them: channel 0 rises left to right in the pattern.
  EXPECT_LT(features.at<float>(0, 0), features.at<float>(0, 3));
  // A box over empty map gives a zero row, not NaN.
  EXPECT_EQ(cv::norm(features.row(2)), 0.0);
}

TEST(LandmarkSimilarity, IdenticalSetsScoreOneAndTheScoreIsSymmetric) {
  const std::vector<cv::Rect2f> boxes_a = {{0, 0, 10, 10}, {20, 0, 10, 20}, {0, 30, 30, 10}};
  cv::Mat features_a = cv::Mat::eye(3, 4, CV_32F);
  EXPECT_NEAR(
      landmarkSimilarity(boxes_a, features_a, boxes_a, features_a, ShapeWeighting::kPenalise), 1.0,
      1e-9);
  const std::vector<cv::Rect2f> boxes_b = {{5, 5, 12, 8}, {0, 0, 10, 10}};
  cv::Mat features_b = (cv::Mat_<float>(2, 4) << 0.6f, 0.8f, 0, 0, 0, 0, 0.8f, 0.6f);
  for (const ShapeWeighting weighting : {ShapeWeighting::kPenalise, ShapeWeighting::kPaper}) {
    EXPECT_DOUBLE_EQ(landmarkSimilarity(boxes_a, features_a, boxes_b, features_b, weighting),
                     landmarkSimilarity(boxes_b, features_b, boxes_a, features_a, weighting));
  }
}

TEST(LandmarkSimilarity, ShapeDisagreementLowersThePenalisingFormAndRaisesThePaperForm) {
  const cv::Mat features = (cv::Mat_<float>(1, 2) << 0.8f, 0.6f);
  const cv::Mat close = (cv::Mat_<float>(1, 2) << 0.6f, 0.8f);  // cos = 0.96.
  const std::vector<cv::Rect2f> square = {{0, 0, 20, 20}};
  const std::vector<cv::Rect2f> same_shape = {{50, 50, 20, 20}};
  const std::vector<cv::Rect2f> thin = {{50, 50, 5, 40}};
  const double penalise_same =
      landmarkSimilarity(square, features, same_shape, close, ShapeWeighting::kPenalise);
  const double penalise_thin =
      landmarkSimilarity(square, features, thin, close, ShapeWeighting::kPenalise);
  EXPECT_NEAR(penalise_same, 0.96, 1e-6);
  EXPECT_LT(penalise_thin, penalise_same);
  EXPECT_GT(landmarkSimilarity(square, features, thin, close, ShapeWeighting::kPaper),
            landmarkSimilarity(square, features, same_shape, close, ShapeWeighting::kPaper));
}

TEST(LandmarkSimilarity, OnlyMutualNearestNeighboursCount) {
  // Both of A's landmarks prefer B's first; B's first prefers A's first: one pair counts.
  const std::vector<cv::Rect2f> boxes = {{0, 0, 10, 10}, {0, 0, 10, 10}};
  const cv::Mat features_a = (cv::Mat_<float>(2, 2) << 1.0f, 0.0f, 0.8f, 0.6f);
  const cv::Mat features_b = (cv::Mat_<float>(2, 2) << 1.0f, 0.0f, -1.0f, 0.0f);
  EXPECT_NEAR(landmarkSimilarity(boxes, features_a, boxes, features_b, ShapeWeighting::kPenalise),
              1.0 / 2.0, 1e-6);
}

TEST(LandmarkSimilarity, NoLandmarksScoresZero) {
  EXPECT_EQ(landmarkSimilarity({}, cv::Mat(), {{0, 0, 1, 1}}, cv::Mat::ones(1, 2, CV_32F),
                               ShapeWeighting::kPenalise),
            0.0);
}

TEST(LandmarkMatches, AreMutualNearestNeighboursWithTheirCosine) {
  const cv::Mat a = (cv::Mat_<float>(3, 2) << 1, 0, 0, 1, 0.8f, 0.6f);
  const cv::Mat b = (cv::Mat_<float>(2, 2) << 0, 1, 1, 0);
  const std::vector<LandmarkMatch> matches = matchLandmarks(a, b);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].a, 0);
  EXPECT_EQ(matches[0].b, 1);
  EXPECT_FLOAT_EQ(matches[0].cosine, 1.0f);
  EXPECT_EQ(matches[1].a, 1);
  EXPECT_EQ(matches[1].b, 0);
  EXPECT_TRUE(matchLandmarks(a, cv::Mat()).empty());
}

TEST(LandmarkMatches, Float16StorageMatchesLikeFloat32) {
  cv::RNG random(7);
  cv::Mat a(12, 40, CV_32F);
  cv::Mat b(9, 40, CV_32F);
  random.fill(a, cv::RNG::NORMAL, 0, 1);
  random.fill(b, cv::RNG::NORMAL, 0, 1);
  for (cv::Mat* m : {&a, &b}) {
    for (int r = 0; r < m->rows; ++r) cv::normalize(m->row(r), m->row(r));
  }
  cv::Mat a16;
  cv::Mat b16;
  a.convertTo(a16, CV_16F);
  b.convertTo(b16, CV_16F);
  const std::vector<LandmarkMatch> full = matchLandmarks(a, b);
  const std::vector<LandmarkMatch> half = matchLandmarks(a16, b16);
  ASSERT_EQ(full.size(), half.size());
  for (size_t i = 0; i < full.size(); ++i) {
    EXPECT_EQ(full[i].a, half[i].a);
    EXPECT_EQ(full[i].b, half[i].b);
    EXPECT_NEAR(full[i].cosine, half[i].cosine, 2e-3);
  }
  // Symmetric: swapping the sets swaps the pairs.
  const std::vector<LandmarkMatch> swapped = matchLandmarks(b16, a16);
  ASSERT_EQ(swapped.size(), half.size());
  for (const LandmarkMatch& m : swapped) {
    EXPECT_NE(std::find_if(half.begin(), half.end(),
                           [&](const LandmarkMatch& h) { return h.a == m.b && h.b == m.a; }),
              half.end());
  }
}

TEST(LandmarkProposals, BoxesLargerThanTheAreaLimitAreNoLandmarks) {
  FeatureMaps maps = zeros(2, 10, 10);
  fill(&maps, 0, cv::Rect(0, 0, 9, 9), 1.0f);  // 81 % of the map.
  fill(&maps, 1, cv::Rect(2, 2, 3, 3), 0.5f);
  LandmarkProposalOptions options;
  options.max_area_fraction = 1.0;
  EXPECT_EQ(proposeLandmarks(maps, cv::Size(100, 100), options).size(), 2u);
  options.max_area_fraction = 0.5;
  const std::vector<LandmarkProposal> kept = proposeLandmarks(maps, cv::Size(100, 100), options);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].channel, 1);
}

namespace {

// A grey image with a few oriented stripes and blobs: enough gradient structure for HOG.
cv::Mat texturedImage(cv::Size size, int seed) {
  cv::Mat image(size, CV_8UC1, cv::Scalar(100));
  cv::RNG random(seed);
  for (int i = 0; i < 40; ++i) {
    const cv::Point a(random.uniform(0, size.width), random.uniform(0, size.height));
    const cv::Point b(random.uniform(0, size.width), random.uniform(0, size.height));
    cv::line(image, a, b, cv::Scalar(random.uniform(0, 255)), random.uniform(1, 4));
  }
  return image;
}

}  // namespace

TEST(LandmarkDescriptors, HogOfTheBoxPatchFollowsTheBoxAcrossScales) {
  const cv::Mat image = texturedImage(cv::Size(320, 240), 3);
  cv::Mat larger;
  cv::resize(image, larger, cv::Size(640, 480), 0, 0, cv::INTER_LINEAR);
  const cv::Size frame(160, 120);  // Boxes are given in this frame, whatever the image size.
  const std::vector<cv::Rect2f> boxes = {{20, 20, 40, 30}, {90, 50, 50, 50}, {300, 300, 10, 10}};
  const cv::Mat small_features = describeLandmarksByHog(image, frame, boxes, 32);
  const cv::Mat large_features = describeLandmarksByHog(larger, frame, boxes, 32);
  ASSERT_EQ(small_features.rows, 3);
  ASSERT_EQ(small_features.cols, kLandmarkHogDimension);
  for (int r = 0; r < 2; ++r) {
    EXPECT_NEAR(cv::norm(small_features.row(r)), 1.0, 1e-4);
    EXPECT_NEAR(cv::mean(small_features.row(r))[0], 0.0, 1e-4);  // Centred.
    // The same patch at twice the resolution: nearly the same descriptor.
    EXPECT_GT(small_features.row(r).dot(large_features.row(r)), 0.9);
  }
  // Different patches differ; a box outside the image is a zero row, not NaN.
  EXPECT_LT(small_features.row(0).dot(small_features.row(1)), 0.5);
  EXPECT_EQ(cv::norm(small_features.row(2)), 0.0);
  EXPECT_EQ(describeLandmarksByHog(cv::Mat(), frame, boxes, 32).rows, 3);
}
