// Per-condition standardisation: what a stretch of keyframes shares is removed, what tells places
// apart is kept.
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {
namespace {

constexpr int kDimension = 64;

std::vector<float> normalised(std::vector<float> v) {
  double norm = 0.0;
  for (float x : v) norm += double(x) * x;
  for (float& x : v) x = static_cast<float>(x / std::sqrt(norm));
  return v;
}

std::vector<float> randomVector(std::mt19937* random, double scale = 1.0) {
  std::normal_distribution<float> normal(0.0f, static_cast<float>(scale));
  std::vector<float> v(kDimension);
  for (float& x : v) x = normal(*random);
  return v;
}

std::vector<float> sum(const std::vector<float>& a, const std::vector<float>& b) {
  std::vector<float> out(a.size());
  for (size_t i = 0; i < a.size(); ++i) out[i] = a[i] + b[i];
  return out;
}

TEST(ConditionStandardiser, OffPassesVectorsUnchanged) {
  ConditionStandardiser off(0);
  EXPECT_FALSE(off.enabled());
  std::mt19937 random(1);
  const std::vector<float> v = normalised(randomVector(&random));
  EXPECT_EQ(off.apply(v), v);
  EXPECT_EQ(off.apply(v), v);
  EXPECT_EQ(off.held(), 0u);
}

TEST(ConditionStandardiser, FirstVectorMatchesNothingThenTheWindowMeanIsRemoved) {
  ConditionStandardiser standardiser(3);
  std::mt19937 random(2);
  std::vector<std::vector<float>> vectors;
  for (int i = 0; i < 6; ++i) vectors.push_back(normalised(randomVector(&random)));
  EXPECT_EQ(standardiser.apply(vectors[0]), std::vector<float>(kDimension, 0.0f));
  for (int i = 1; i < 6; ++i) {
    const std::vector<float> out = standardiser.apply(vectors[i]);
    // Expected: the vector less the mean of the last three (itself included), normalised.
    const int first = std::max(0, i - 2);
    std::vector<float> expected(kDimension, 0.0f);
    for (int d = 0; d < kDimension; ++d) {
      double mean = 0.0;
      for (int j = first; j <= i; ++j) mean += vectors[j][d];
      expected[d] = static_cast<float>(vectors[i][d] - mean / (i - first + 1));
    }
    expected = normalised(expected);
    ASSERT_EQ(out.size(), expected.size());
    for (int d = 0; d < kDimension; ++d) EXPECT_NEAR(out[d], expected[d], 1e-5) << i << " " << d;
  }
  EXPECT_EQ(standardiser.held(), 3u);
}

TEST(ConditionStandardiser, WarmsUpUntilFullAndStandardisesAnEarlierVectorWithoutAddingIt) {
  ConditionStandardiser standardiser(3);
  std::mt19937 random(5);
  std::vector<std::vector<float>> vectors;
  for (int i = 0; i < 3; ++i) vectors.push_back(normalised(randomVector(&random)));
  EXPECT_TRUE(standardiser.warmingUp());
  standardiser.apply(vectors[0]);
  standardiser.apply(vectors[1]);
  EXPECT_TRUE(standardiser.warmingUp());
  standardiser.apply(vectors[2]);
  EXPECT_FALSE(standardiser.warmingUp());
  // The first vector, which apply() could only tell apart from nothing, less the full window's
  // mean; the window is left as it was.
  const std::vector<float> out = standardiser.standardise(vectors[0]);
  std::vector<float> expected(kDimension, 0.0f);
  for (int d = 0; d < kDimension; ++d) {
    expected[d] = vectors[0][d] - (vectors[0][d] + vectors[1][d] + vectors[2][d]) / 3.0f;
  }
  expected = normalised(expected);
  for (int d = 0; d < kDimension; ++d) EXPECT_NEAR(out[d], expected[d], 1e-5) << d;
  EXPECT_EQ(standardiser.held(), 3u);
  EXPECT_FALSE(ConditionStandardiser(0).warmingUp());
}

// Places p_i seen under two conditions: day (a small shared part) and night (a large shared part
// that makes every night frame alike). After standardisation within each condition, two night
// frames of different places no longer look alike, and the same place matches across conditions.
TEST(ConditionStandardiser, DarknessSharedByEveryFrameStopsCountingAsLikeness) {
  std::mt19937 random(3);
  const int places = 40;
  std::vector<std::vector<float>> place;
  for (int i = 0; i < places; ++i) place.push_back(randomVector(&random));
  const std::vector<float> day = randomVector(&random, 0.5);
  const std::vector<float> night = randomVector(&random, 3.0);

  ConditionStandardiser standardiser(10);
  std::vector<std::vector<float>> day_raw, night_raw, day_out, night_out;
  for (int i = 0; i < places; ++i) {
    day_raw.push_back(normalised(sum(place[i], day)));
    day_out.push_back(standardiser.apply(day_raw.back()));
  }
  for (int i = 0; i < places; ++i) {
    night_raw.push_back(normalised(sum(place[i], night)));
    night_out.push_back(standardiser.apply(night_raw.back()));
  }
  // Compare after the window has filled with night frames.
  double raw_night_pairs = 0.0, standardised_night_pairs = 0.0;
  double raw_same_place = 0.0, standardised_same_place = 0.0;
  int pairs = 0, same = 0;
  for (int i = 20; i < places; ++i) {
    for (int j = 10; j + 5 < i; ++j) {
      raw_night_pairs += cosineSimilarity(night_raw[i], night_raw[j]);
      standardised_night_pairs += cosineSimilarity(night_out[i], night_out[j]);
      ++pairs;
    }
    raw_same_place += cosineSimilarity(night_raw[i], day_raw[i]);
    standardised_same_place += cosineSimilarity(night_out[i], day_out[i]);
    ++same;
  }
  raw_night_pairs /= pairs;
  standardised_night_pairs /= pairs;
  raw_same_place /= same;
  standardised_same_place /= same;
  // Raw: different night places look more alike than one place by day and by night.
  EXPECT_GT(raw_night_pairs, raw_same_place);
  // Standardised: the other way round, by far.
  EXPECT_LT(standardised_night_pairs, 0.1);
  EXPECT_GT(standardised_same_place, 0.5);
}

TEST(ConditionStandardiser, AnotherLengthRestartsTheWindow) {
  ConditionStandardiser standardiser(5);
  std::mt19937 random(4);
  standardiser.apply(normalised(randomVector(&random)));
  standardiser.apply(normalised(randomVector(&random)));
  EXPECT_EQ(standardiser.held(), 2u);
  const std::vector<float> longer(kDimension + 1, 0.5f);
  EXPECT_EQ(standardiser.apply(longer), std::vector<float>(kDimension + 1, 0.0f));
  EXPECT_EQ(standardiser.held(), 1u);
}

TEST(ConditionStandardiser, NonFiniteValuesCountAsZeroAndRepeatsMatchNothing) {
  ConditionStandardiser standardiser(4);
  std::vector<float> bad(kDimension, 0.1f);
  bad[3] = std::numeric_limits<float>::quiet_NaN();
  bad[5] = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 6; ++i) {
    // The same vector again and again equals the window's mean: nothing tells it apart.
    const std::vector<float> out = standardiser.apply(bad);
    for (float x : out) EXPECT_EQ(x, 0.0f);
  }
  // Another vector then differs from the window's mean, non-finite values read as 0.
  std::vector<float> other(kDimension, 0.1f);
  other[0] = 1.0f;
  other[3] = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> out = standardiser.apply(other);
  for (float x : out) EXPECT_TRUE(std::isfinite(x));
  EXPECT_GT(out[0], 0.5f);
  EXPECT_EQ(out[3], 0.0f);
}

}  // namespace
}  // namespace landmark_loop_closure
