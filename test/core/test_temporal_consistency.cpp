#include <gtest/gtest.h>

#include "landmark_loop_closure/core/temporal_consistency.h"

using namespace landmark_loop_closure;

namespace {

// Keyframe-counted chains: the query's place on the path does not matter.
std::vector<int> update(TemporalConsistency* consistency, const std::vector<uint64_t>& match_ids) {
  std::vector<PathPoint> matches;
  for (const uint64_t id : match_ids) matches.push_back({id, 0.0});
  std::vector<int> lengths;
  for (const auto& chain : consistency->update({}, matches)) lengths.push_back(chain.keyframes);
  return lengths;
}

}  // namespace

TEST(TemporalConsistency, ChainsGrowWhenMatchesStayInTheWindow) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 2);
  EXPECT_EQ(update(&consistency, {10}), std::vector<int>({1}));
  EXPECT_EQ(update(&consistency, {11}), std::vector<int>({2}));
  EXPECT_EQ(update(&consistency, {13}), std::vector<int>({3}));
  EXPECT_EQ(update(&consistency, {12}), std::vector<int>({4}));  // Backwards a little is fine.
}

TEST(TemporalConsistency, AJumpToAnotherPlaceStartsAgain) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 2);
  update(&consistency, {10});
  update(&consistency, {11});
  EXPECT_EQ(update(&consistency, {50}), std::vector<int>({1}));
  EXPECT_EQ(update(&consistency, {51}), std::vector<int>({2}));
}

TEST(TemporalConsistency, AKeyframeWithoutMatchesBreaksTheChain) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 2);
  update(&consistency, {10});
  update(&consistency, {11});
  update(&consistency, {});
  EXPECT_EQ(update(&consistency, {12}), std::vector<int>({1}));
}

TEST(TemporalConsistency, EachCandidateKeepsItsOwnChain) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 1);
  update(&consistency, {10, 40});
  update(&consistency, {11, 80});
  EXPECT_EQ(update(&consistency, {12, 81, 200}), std::vector<int>({3, 2, 1}));
}

TEST(TemporalConsistency, ResetForgetsEverything) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 5);
  update(&consistency, {10});
  consistency.reset();
  EXPECT_EQ(update(&consistency, {10}), std::vector<int>({1}));
}

TEST(TemporalConsistency, WindowZeroNeedsTheSameMatch) {
  TemporalConsistency consistency(ConsistencyUnit::kKeyframes, 0);
  update(&consistency, {10});
  EXPECT_EQ(update(&consistency, {11}), std::vector<int>({1}));
  EXPECT_EQ(update(&consistency, {11}), std::vector<int>({2}));
}

TEST(TemporalConsistency, MetreChainsMeasureTheQuerysTravel) {
  TemporalConsistency consistency(ConsistencyUnit::kMetres, 0.5);
  // The query drives 0.4 m per keyframe past a stretch it saw before, 100 m earlier on its path.
  EXPECT_DOUBLE_EQ(consistency.update({200, 100.0}, {{10, 0.0}})[0].metres, 0.0);
  EXPECT_NEAR(consistency.update({201, 100.4}, {{11, 0.4}})[0].metres, 0.4, 1e-12);
  const auto chain = consistency.update({202, 100.8}, {{12, 0.8}})[0];
  EXPECT_EQ(chain.keyframes, 3);
  EXPECT_NEAR(chain.metres, 0.8, 1e-12);
}

TEST(TemporalConsistency, MetreWindowGrowsWithTheQuerysStep) {
  // Sparse keyframes (a fast robot): matches 1.5 m apart still continue the chain when the query
  // itself moved 1.5 m, whatever the keyframe ids.
  TemporalConsistency consistency(ConsistencyUnit::kMetres, 0.3);
  consistency.update({50, 10.0}, {{5, 0.0}});
  const auto chains = consistency.update({51, 11.5}, {{9, 1.5}, {30, 4.0}});
  EXPECT_EQ(chains[0].keyframes, 2);
  EXPECT_NEAR(chains[0].metres, 1.5, 1e-12);
  EXPECT_EQ(chains[1].keyframes, 1);  // 4 m away along the old path: another place.
}

TEST(TemporalConsistency, MetreChainsDoNotGrowWhileTheQueryStands) {
  // A robot turning on the spot keeps matching, but the chain covers no distance: in metres a loop
  // needs the place confirmed along the way.
  TemporalConsistency consistency(ConsistencyUnit::kMetres, 0.5);
  TemporalConsistency::Chain chain;
  for (int i = 0; i < 10; ++i) {
    chain = consistency.update({static_cast<uint64_t>(100 + i), 42.0}, {{7, 3.0}})[0];
  }
  EXPECT_EQ(chain.keyframes, 10);
  EXPECT_DOUBLE_EQ(chain.metres, 0.0);
}

TEST(TemporalConsistency, UnitNames) {
  ConsistencyUnit unit = ConsistencyUnit::kKeyframes;
  EXPECT_TRUE(parseConsistencyUnit("metres", &unit));
  EXPECT_EQ(unit, ConsistencyUnit::kMetres);
  EXPECT_TRUE(parseConsistencyUnit("keyframes", &unit));
  EXPECT_EQ(unit, ConsistencyUnit::kKeyframes);
  EXPECT_FALSE(parseConsistencyUnit("meters", &unit));
}
