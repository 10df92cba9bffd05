// The appearance check: feature-map cells matched mutually and explained by one affine map.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/appearance_check.h"

namespace landmark_loop_closure {
namespace {

constexpr int kWidth = 16;
constexpr int kHeight = 9;
constexpr int kChannels = 32;

// A scene: one random feature vector per position of a wider world than one view.
struct Scene {
  explicit Scene(unsigned seed, int width = kWidth + 8) : width(width) {
    std::mt19937 random(seed);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    values.resize(static_cast<size_t>(width) * kHeight * kChannels);
    for (float& v : values) v = std::max(0.0f, normal(random));  // ReLU-like maps.
  }
  float at(int c, int y, int x) const {
    return values[(static_cast<size_t>(c) * kHeight + y) * width + x];
  }
  int width;
  std::vector<float> values;
};

// The view of `scene` starting `offset` columns in, with multiplicative "light" and noise.
FeatureMaps view(const Scene& scene, int offset, float light, float noise, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<float> normal(0.0f, noise);
  FeatureMaps maps;
  maps.channels = kChannels;
  maps.height = kHeight;
  maps.width = kWidth;
  maps.values.resize(static_cast<size_t>(kChannels) * kHeight * kWidth);
  for (int c = 0; c < kChannels; ++c) {
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        maps.values[(static_cast<size_t>(c) * kHeight + y) * kWidth + x] =
            light * scene.at(c, y, x + offset) + normal(random);
      }
    }
  }
  return maps;
}

TEST(AppearanceCheck, TheSamePlaceShiftedAndDarkerIsConfirmed) {
  const Scene scene(1);
  const AppearanceCheckOptions options;
  const AppearanceCheckResult result =
      checkAppearance(cellFeatures(view(scene, 0, 1.0f, 0.2f, 2)),
                      cellFeatures(view(scene, 3, 0.2f, 0.05f, 3)), options);
  EXPECT_TRUE(result.confirmed) << result.describe();
  EXPECT_GE(result.inliers, 80);
  EXPECT_NE(result.describe().find("cells agree"), std::string::npos);
}

TEST(AppearanceCheck, AnotherPlaceIsRefused) {
  const AppearanceCheckOptions options;
  const AppearanceCheckResult result =
      checkAppearance(cellFeatures(view(Scene(1), 0, 1.0f, 0.2f, 2)),
                      cellFeatures(view(Scene(7), 0, 1.0f, 0.2f, 3)), options);
  EXPECT_FALSE(result.confirmed) << result.describe();
  EXPECT_LT(result.inliers, options.min_inliers);
}

// The same cells in another layout (a place that shares textures but not their arrangement).
TEST(AppearanceCheck, TheSameTexturesShuffledAreRefused) {
  const Scene scene(4);
  FeatureMaps shuffled = view(scene, 0, 1.0f, 0.1f, 5);
  std::vector<int> order(kWidth * kHeight);
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::shuffle(order.begin(), order.end(), std::mt19937(6));
  const FeatureMaps original = shuffled;
  for (int c = 0; c < kChannels; ++c) {
    for (size_t i = 0; i < order.size(); ++i) {
      shuffled.values[c * order.size() + i] = original.values[c * order.size() + order[i]];
    }
  }
  const AppearanceCheckOptions options;
  const AppearanceCheckResult result =
      checkAppearance(cellFeatures(original), cellFeatures(shuffled), options);
  EXPECT_GT(result.mutual_matches, 100);                // Every cell finds its twin ...
  EXPECT_FALSE(result.confirmed) << result.describe();  // ... but not in one layout.
}

TEST(AppearanceCheck, EmptyOrMismatchedMapsAreNotConfirmed) {
  const AppearanceCheckOptions options;
  const CellFeatures cells = cellFeatures(view(Scene(1), 0, 1.0f, 0.1f, 2));
  EXPECT_TRUE(cellFeatures(FeatureMaps{}).empty());
  EXPECT_FALSE(checkAppearance(cells, CellFeatures{}, options).confirmed);
  FeatureMaps fewer_channels = view(Scene(1), 0, 1.0f, 0.1f, 2);
  fewer_channels.channels = kChannels / 2;
  fewer_channels.values.resize(static_cast<size_t>(kChannels / 2) * kHeight * kWidth);
  const AppearanceCheckResult result =
      checkAppearance(cells, cellFeatures(fewer_channels), options);
  EXPECT_FALSE(result.confirmed);
  EXPECT_EQ(result.mutual_matches, 0);
}

// A candidate the calibrated decision is sure of needs fewer cells; one it is less sure of, or
// one it did not test (-1), needs min_inliers.
TEST(AppearanceCheck, ACandidateTheDecisionIsSureOfNeedsFewerCells) {
  const Scene scene(1);
  const CellFeatures query = cellFeatures(view(scene, 0, 1.0f, 0.2f, 2));
  const CellFeatures match = cellFeatures(view(scene, 3, 0.2f, 0.05f, 3));
  AppearanceCheckOptions options;
  const int inliers = checkAppearance(query, match, options).inliers;
  options.min_inliers = inliers + 1;
  options.sure_min_inliers = inliers;
  options.sure_false_alarms = 1e-4;
  EXPECT_FALSE(checkAppearance(query, match, options).confirmed);
  EXPECT_FALSE(checkAppearance(query, match, options, {2e-4}).confirmed);
  const AppearanceCheckResult sure = checkAppearance(query, match, options, {1e-5});
  EXPECT_TRUE(sure.confirmed);
  EXPECT_EQ(sure.required, inliers);
  EXPECT_NE(sure.describe().find("(" + std::to_string(inliers) + " needed)"), std::string::npos)
      << sure.describe();
  options.sure_false_alarms = 0.0;  // Off.
  EXPECT_FALSE(checkAppearance(query, match, options, {1e-5}).confirmed);
  // sure_min_inliers above min_inliers never asks for more.
  options.sure_false_alarms = 1e-4;
  options.sure_min_inliers = inliers + 10;
  EXPECT_EQ(requiredCells(options, {1e-5}), inliers + 1);
}

// A candidate continuing the loop the keyframe before published needs continuing_min_inliers
// when that is set, whatever the decision's estimate; never more than the others would.
TEST(AppearanceCheck, ACandidateContinuingALoopNeedsContinuingMinInliers) {
  const Scene scene(1);
  const CellFeatures query = cellFeatures(view(scene, 0, 1.0f, 0.2f, 2));
  const CellFeatures match = cellFeatures(view(scene, 3, 0.2f, 0.05f, 3));
  AppearanceCheckOptions options;
  const int inliers = checkAppearance(query, match, options).inliers;
  options.min_inliers = inliers + 2;
  options.sure_min_inliers = inliers + 1;
  options.continuing_min_inliers = inliers;
  EXPECT_FALSE(checkAppearance(query, match, options, {1e-2, false}).confirmed);
  EXPECT_FALSE(checkAppearance(query, match, options, {1e-5, false}).confirmed);
  const AppearanceCheckResult continuing = checkAppearance(query, match, options, {1e-2, true});
  EXPECT_TRUE(continuing.confirmed);
  EXPECT_EQ(continuing.required, inliers);
  options.continuing_min_inliers = 0;  // Off.
  EXPECT_FALSE(checkAppearance(query, match, options, {1e-2, true}).confirmed);
  EXPECT_EQ(requiredCells(options, {1e-5, true}), inliers + 1);
  options.continuing_min_inliers = inliers + 10;
  EXPECT_EQ(requiredCells(options, {1e-2, true}), inliers + 2);
}

TEST(AppearanceCheck, OptionsSayWhatIsWrong) {
  AppearanceCheckOptions options;
  EXPECT_EQ(options.validate(), "");
  options.min_inliers = 2;
  EXPECT_NE(options.validate().find("advanced/verification/appearance/min_inliers"),
            std::string::npos);
  options = {};
  options.ransac_threshold_cells = 0.0;
  EXPECT_NE(options.validate().find("ransac_threshold_cells"), std::string::npos);
}

}  // namespace
}  // namespace landmark_loop_closure
