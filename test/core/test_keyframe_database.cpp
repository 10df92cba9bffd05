#include <gtest/gtest.h>

#include "landmark_loop_closure/keyframe_database.h"

using namespace landmark_loop_closure;

namespace {

// Unit vectors in 2-D at the given angle: cosine similarity is cos(angle difference).
std::vector<float> direction(double angle) {
  return {static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle))};
}

KeyframeRecord keyframe(uint64_t id, double stamp, double angle) {
  KeyframeRecord k;
  k.id = id;
  k.stamp = stamp;
  k.descriptor.global = direction(angle);
  return k;
}

DatabaseOptions noExclusion() {
  DatabaseOptions options;
  options.exclude_recent_keyframes = 0;
  options.exclude_recent_seconds = 0.0;
  options.min_size = 1;
  options.top_k = 3;
  return options;
}

}  // namespace

TEST(KeyframeDatabase, ReturnsTopKBestFirst) {
  KeyframeDatabase database(2);
  for (int i = 0; i < 10; ++i) database.add(keyframe(i, i, 0.1 * i));
  const QueryResult result = database.query(direction(0.42), 100.0, noExclusion());
  ASSERT_EQ(result.status, QueryStatus::kSearched);
  ASSERT_EQ(result.candidates.size(), 3u);
  EXPECT_EQ(result.candidates[0].id, 4u);
  EXPECT_EQ(result.candidates[1].id, 5u);
  EXPECT_EQ(result.candidates[2].id, 3u);
  EXPECT_GE(result.candidates[0].global_score, result.candidates[1].global_score);
  EXPECT_EQ(result.searched, 10u);
}

TEST(KeyframeDatabase, RefusesToSearchBeforeMinimumSize) {
  KeyframeDatabase database(2);
  DatabaseOptions options = noExclusion();
  options.min_size = 5;
  for (int i = 0; i < 4; ++i) database.add(keyframe(i, i, 0.0));
  EXPECT_EQ(database.query(direction(0), 100, options).status, QueryStatus::kDatabaseTooSmall);
  database.add(keyframe(4, 4, 0.0));
  EXPECT_EQ(database.query(direction(0), 100, options).status, QueryStatus::kSearched);
}

TEST(KeyframeDatabase, ExcludesTheMostRecentKeyframesByCount) {
  KeyframeDatabase database(2);
  for (int i = 0; i < 10; ++i) database.add(keyframe(i, i, 0.1 * i));
  DatabaseOptions options = noExclusion();
  options.exclude_recent_keyframes = 4;
  options.top_k = 10;
  const QueryResult result = database.query(direction(0.9), 1000.0, options);
  EXPECT_EQ(result.searched, 6u);
  for (const Candidate& c : result.candidates) EXPECT_LT(c.id, 6u);
  EXPECT_EQ(result.candidates.front().id, 5u);  // Closest allowed to angle 0.9.
}

TEST(KeyframeDatabase, ExcludesKeyframesCloseInTime) {
  KeyframeDatabase database(2);
  for (int i = 0; i < 10; ++i) database.add(keyframe(i, i, 0.0));
  DatabaseOptions options = noExclusion();
  options.exclude_recent_seconds = 3.5;
  options.top_k = 10;
  const QueryResult result = database.query(direction(0), 10.0, options);
  EXPECT_EQ(result.searched, 7u);  // Stamps 7, 8, 9 are within 3.5 s of 10.
  for (const Candidate& c : result.candidates) EXPECT_LE(c.id, 6u);
}

TEST(KeyframeDatabase, EverythingExcludedIsReported) {
  KeyframeDatabase database(2);
  for (int i = 0; i < 3; ++i) database.add(keyframe(i, i, 0.0));
  DatabaseOptions options = noExclusion();
  options.exclude_recent_keyframes = 5;
  const QueryResult result = database.query(direction(0), 10.0, options);
  EXPECT_EQ(result.status, QueryStatus::kAllExcluded);
  EXPECT_TRUE(result.candidates.empty());
}

TEST(KeyframeDatabase, RefusesBadKeyframesAndKeepsWhatItHas) {
  KeyframeDatabase database(2);
  database.add(keyframe(5, 1.0, 0.0));
  EXPECT_THROW(database.add(keyframe(5, 2.0, 0.0)), std::invalid_argument);
  EXPECT_THROW(database.add(keyframe(3, 2.0, 0.0)), std::invalid_argument);
  KeyframeRecord wrong_length = keyframe(6, 2.0, 0.0);
  wrong_length.descriptor.global.push_back(0.0f);
  EXPECT_THROW(database.add(wrong_length), std::invalid_argument);
  ASSERT_EQ(database.size(), 1u);
  EXPECT_EQ(database.at(0).id, 5u);
}

TEST(KeyframeDatabase, FindsById) {
  KeyframeDatabase database(2);
  for (uint64_t id : {2u, 4u, 9u}) database.add(keyframe(id, id, 0.0));
  ASSERT_NE(database.findById(4), nullptr);
  EXPECT_EQ(database.findById(4)->stamp, 4.0);
  EXPECT_EQ(database.findById(5), nullptr);
  EXPECT_EQ(database.findById(100), nullptr);
  EXPECT_GT(database.bytes(), 3 * 2 * sizeof(float));
}

TEST(DatabaseOptions, ValidateNamesTheKey) {
  EXPECT_EQ(DatabaseOptions{}.validate(), "");
  DatabaseOptions options;
  options.top_k = 0;
  EXPECT_NE(options.validate().find("database/top_k"), std::string::npos);
}
