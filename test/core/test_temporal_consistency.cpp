#include <gtest/gtest.h>

#include "landmark_loop_closure/temporal_consistency.h"

using namespace landmark_loop_closure;

TEST(TemporalConsistency, ChainsGrowWhenMatchesStayInTheWindow) {
  TemporalConsistency consistency(2);
  EXPECT_EQ(consistency.update({10}), std::vector<int>({1}));
  EXPECT_EQ(consistency.update({11}), std::vector<int>({2}));
  EXPECT_EQ(consistency.update({13}), std::vector<int>({3}));
  EXPECT_EQ(consistency.update({12}), std::vector<int>({4}));  // Backwards a little is fine.
}

TEST(TemporalConsistency, AJumpToAnotherPlaceStartsAgain) {
  TemporalConsistency consistency(2);
  consistency.update({10});
  consistency.update({11});
  EXPECT_EQ(consistency.update({50}), std::vector<int>({1}));
  EXPECT_EQ(consistency.update({51}), std::vector<int>({2}));
}

TEST(TemporalConsistency, AKeyframeWithoutMatchesBreaksTheChain) {
  TemporalConsistency consistency(2);
  consistency.update({10});
  consistency.update({11});
  consistency.update({});
  EXPECT_EQ(consistency.update({12}), std::vector<int>({1}));
}

TEST(TemporalConsistency, EachCandidateKeepsItsOwnChain) {
  TemporalConsistency consistency(1);
  consistency.update({10, 40});
  consistency.update({11, 80});
  EXPECT_EQ(consistency.update({12, 81, 200}), std::vector<int>({3, 2, 1}));
}

TEST(TemporalConsistency, ResetForgetsEverything) {
  TemporalConsistency consistency(5);
  consistency.update({10});
  consistency.reset();
  EXPECT_EQ(consistency.update({10}), std::vector<int>({1}));
}

TEST(TemporalConsistency, WindowZeroNeedsTheSameMatch) {
  TemporalConsistency consistency(0);
  consistency.update({10});
  EXPECT_EQ(consistency.update({11}), std::vector<int>({1}));
  EXPECT_EQ(consistency.update({11}), std::vector<int>({2}));
}
