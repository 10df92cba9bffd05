#include <gtest/gtest.h>

#include <cmath>

#include "landmark_loop_closure/core/place_distinctiveness.h"

namespace landmark_loop_closure {
namespace {

TEST(PlaceRatios, DistinctPlaceStandsOutOfItsShortlist) {
  // One place (ids 100-102) far above two others.
  const std::vector<ShortlistEntry> shortlist = {
      {101, 0, 0.6}, {100, 0, 0.5}, {400, 0, 0.3}, {800, 0, 0.25}};
  const std::vector<double> ratios = placeRatios(shortlist, 10);
  ASSERT_EQ(ratios.size(), 4u);
  EXPECT_DOUBLE_EQ(ratios[0], 0.6 / 0.3);  // Its neighbour 100 is the same place.
  EXPECT_DOUBLE_EQ(ratios[1], 0.5 / 0.3);
  EXPECT_DOUBLE_EQ(ratios[2], 0.3 / 0.6);
  EXPECT_DOUBLE_EQ(ratios[3], 0.25 / 0.6);
}

TEST(PlaceRatios, AlikePlacesAreAmbiguous) {
  const std::vector<ShortlistEntry> shortlist = {{50, 0, 0.45}, {700, 0, 0.44}};
  const std::vector<double> ratios = placeRatios(shortlist, 10);
  EXPECT_NEAR(ratios[0], 0.45 / 0.44, 1e-12);
  EXPECT_LT(ratios[0], 1.2);
}

TEST(PlaceRatios, WindowDecidesWhatIsAnotherPlace) {
  const std::vector<ShortlistEntry> shortlist = {{100, 0, 0.6}, {105, 0, 0.58}, {200, 0, 0.2}};
  EXPECT_DOUBLE_EQ(placeRatios(shortlist, 10)[0], 0.6 / 0.2);
  EXPECT_DOUBLE_EQ(placeRatios(shortlist, 4)[0], 0.6 / 0.58);
}

TEST(PlaceRatios, OtherSessionsAreNotCompetitors) {
  // The same place in an earlier session's map and in this one: not ambiguous.
  const std::vector<ShortlistEntry> shortlist = {{10, 0, 0.5}, {900, 1, 0.5}, {300, 1, 0.2}};
  const std::vector<double> ratios = placeRatios(shortlist, 10);
  EXPECT_DOUBLE_EQ(ratios[0], 0.5 / 0.2);  // Alone in session 0: the lowest score stands in.
  EXPECT_DOUBLE_EQ(ratios[1], 0.5 / 0.2);
}

TEST(PlaceRatios, OdometrySaysLapsAreOnePlace) {
  // Lap 1 and lap 2 of a run at one spot: far apart in ids, one place by odometry.
  const std::vector<ShortlistEntry> shortlist = {{20, 0, 0.5}, {220, 0, 0.49}, {120, 0, 0.25}};
  const auto laps = [](size_t a, size_t b) { return (a == 0 && b == 1) || (a == 1 && b == 0); };
  EXPECT_NEAR(placeRatios(shortlist, 10)[0], 0.5 / 0.49, 1e-12);
  EXPECT_DOUBLE_EQ(placeRatios(shortlist, 10, laps)[0], 0.5 / 0.25);
}

TEST(PlaceRatios, SignsAndEdges) {
  EXPECT_TRUE(placeRatios({}, 10).empty());
  // Alone: the lowest shortlist score is its own, ratio 1.
  EXPECT_DOUBLE_EQ(placeRatios({{5, 0, 0.4}}, 10)[0], 1.0);
  const std::vector<double> ratios = placeRatios({{5, 0, 0.3}, {50, 0, -0.1}}, 10);
  EXPECT_TRUE(std::isinf(ratios[0]));
  EXPECT_DOUBLE_EQ(ratios[1], 0.0);
}

// A loop from keyframe 100 to match 50, index_window 3, continued across at most 5 keyframes.
TEST(ContinuesStretch, TheNextKeyframeWithinTheWindowOrALaterOneAtTheSamePace) {
  EXPECT_TRUE(continuesStretch(100, 50, 101, 47, 3, 5));  // The next keyframe: either side.
  EXPECT_TRUE(continuesStretch(100, 50, 101, 53, 3, 5));
  EXPECT_FALSE(continuesStretch(100, 50, 101, 54, 3, 5));
  EXPECT_TRUE(continuesStretch(100, 50, 104, 54, 3, 5));  // Four on: the pace puts it at 54,
  EXPECT_TRUE(continuesStretch(100, 50, 104, 52, 3, 5));  // within one less than the window.
  EXPECT_TRUE(continuesStretch(100, 50, 104, 56, 3, 5));
  EXPECT_FALSE(continuesStretch(100, 50, 104, 57, 3, 5));  // Too far ahead.
  EXPECT_FALSE(continuesStretch(100, 50, 104, 51, 3, 5));  // Too slow.
  EXPECT_FALSE(continuesStretch(100, 50, 102, 49, 3, 5));  // Behind the loop's match.
  EXPECT_TRUE(continuesStretch(100, 50, 105, 55, 3, 5));
  EXPECT_FALSE(continuesStretch(100, 50, 106, 56, 3, 5));  // Past `across`.
  EXPECT_FALSE(continuesStretch(100, 50, 100, 50, 3, 5));  // Not after the loop.
  EXPECT_FALSE(continuesStretch(100, 50, 99, 49, 3, 5));
  EXPECT_FALSE(continuesStretch(100, 50, 102, 52, 3, 1));  // 1: the next keyframe only.
}

}  // namespace
}  // namespace landmark_loop_closure
