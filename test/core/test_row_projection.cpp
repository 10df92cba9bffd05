// The database's rows projected onto their leading directions, and the search of a large map
// through them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/row_projection.h"
#include "random_descriptors.h"

namespace landmark_loop_closure {
namespace {

std::vector<float> unit(std::vector<float> vector) {
  double norm = 0.0;
  for (const float v : vector) norm += static_cast<double>(v) * v;
  for (float& v : vector) v = static_cast<float>(v / std::sqrt(norm));
  return vector;
}

DatabaseOptions searchWith(const IndexOptions& index) {
  DatabaseOptions options;
  options.min_size = 1;
  options.exclude_recent_keyframes = 0;
  options.exclude_recent_seconds = 0.0;
  options.top_k = 10;
  options.index = index;
  return options;
}

}  // namespace

TEST(RowProjection, ItsProductIsTheRowsProductWhereTheRowsSpanFewDirections) {
  // Rows mixed from 40 directions of 4 320 values: the learned directions span them, and the
  // product of two projections is the rows' own, to the 8-bit rounding of both.
  const int dimension = 4320;
  std::mt19937 random(11);
  std::normal_distribution<float> normal;
  std::vector<std::vector<float>> bases(40, std::vector<float>(dimension));
  for (auto& base : bases) {
    for (float& v : base) v = normal(random);
  }
  const auto mixed = [&]() {
    std::vector<float> row(dimension, 0.0f);
    for (const auto& base : bases) {
      const float weight = normal(random);
      for (int i = 0; i < dimension; ++i) row[i] += weight * base[i];
    }
    return unit(row);
  };
  QuantizedVectors rows(dimension);
  for (int r = 0; r < 300; ++r) rows.append(mixed().data());
  const RowProjection projection(rows);
  EXPECT_EQ(projection.size(), 300u);
  for (int p = 0; p < 50; ++p) {
    const std::vector<uint8_t> query = QuantizedVectors::encode(mixed());
    const size_t index = static_cast<size_t>(p * 5);
    const RowProjection::Projected projected = projection.project(query.data());
    EXPECT_NEAR(projection.dot(projected, index), rows.dot(query.data(), index), 0.02);
    EXPECT_NEAR(projected.residual, 0.0, 0.05);
  }
}

TEST(RowProjection, TheLeadingDirectionsCarryTheLargestShareOfTheRows) {
  // Rows of 512 values whose first 8 carry most of their energy: the 8 leading directions are
  // kept among the 256, and the projections' products are the rows' within a few hundredths.
  std::mt19937 random(23);
  std::normal_distribution<float> normal;
  QuantizedVectors rows(512);
  std::vector<std::vector<float>> kept;
  for (int r = 0; r < 2000; ++r) {
    std::vector<float> row(512);
    for (int i = 0; i < 512; ++i) row[i] = normal(random) * (i < 8 ? 10.0f : 0.3f);
    kept.push_back(unit(row));
    rows.append(kept.back().data());
  }
  const RowProjection projection(rows);
  EXPECT_EQ(projection.dimension(), RowProjection::kDimension);
  double squared_error = 0.0;
  for (int p = 0; p < 100; ++p) {
    const std::vector<uint8_t> query = QuantizedVectors::encode(kept[static_cast<size_t>(p)]);
    const RowProjection::Projected projected = projection.project(query.data());
    const size_t index = static_cast<size_t>(1000 + p);
    const double exact = rows.dot(query.data(), index);
    const double error = projection.dot(projected, index) - exact;
    squared_error += error * error;
  }
  EXPECT_LT(std::sqrt(squared_error / 100), 0.03);
  EXPECT_THROW(RowProjection(QuantizedVectors(16)), std::invalid_argument);
}

TEST(RowProjection, ALargeMapSearchedThroughThemFindsWhatExactSearchFinds) {
  std::mt19937 random(13);
  const auto vectors = test_support::routeVectors(6000, 512, &random);
  IndexOptions automatic;
  automatic.coarse_from = 5000;  // The projections search this map.
  IndexOptions exact;
  exact.type = "exact";
  const KeyframeDatabase projected_map = test_support::routeDatabase(vectors, automatic);
  const KeyframeDatabase plain = test_support::routeDatabase(vectors, exact);
  EXPECT_GT(projected_map.bytes(), plain.bytes());
  std::normal_distribution<float> noise(0.0f, 0.03f);
  size_t shared = 0;
  size_t wanted = 0;
  for (int q = 0; q < 100; ++q) {
    std::vector<float> query = vectors[static_cast<size_t>(q * 59)];
    for (float& v : query) v += noise(random);
    query = unit(query);
    const QueryResult coarse = projected_map.query(query, 1e9, searchWith(automatic));
    const QueryResult every = plain.query(query, 1e9, searchWith(exact));
    EXPECT_TRUE(coarse.approximate);
    EXPECT_FALSE(every.approximate);
    ASSERT_EQ(coarse.candidates.size(), 10u);
    std::set<uint64_t> exact_ids;
    for (const Candidate& c : every.candidates) exact_ids.insert(c.id);
    for (const Candidate& c : coarse.candidates) {
      shared += exact_ids.count(c.id);
      // A candidate's score is its exact one, and its id the keyframe's.
      EXPECT_FLOAT_EQ(c.global_score, projected_map.similarity(query, c.index));
      EXPECT_EQ(c.id, c.index);
    }
    wanted += exact_ids.size();
  }
  EXPECT_GE(shared, wanted * 99 / 100);
}

TEST(RowProjection, RowsUnlikeTheLearnedOnesAreScoredExactly) {
  // The directions are learned from the first 600 rows (a route in 64 of 512 values); the 200
  // rows after them lie in the other 448 values, which the directions barely describe. Searched
  // again, each of those rows is still found first: it is scored exactly, however low its
  // projection ranks it.
  std::mt19937 random(29);
  std::normal_distribution<float> normal;
  std::vector<std::vector<float>> vectors;
  for (int r = 0; r < 800; ++r) {
    std::vector<float> row(512, 0.0f);
    const int first = r < 600 ? 0 : 64;
    const int count = r < 600 ? 64 : 448;
    for (int i = first; i < first + count; ++i) row[i] = normal(random);
    vectors.push_back(unit(row));
  }
  IndexOptions automatic;
  automatic.coarse_from = 600;
  automatic.coarse_candidates = 20;
  const KeyframeDatabase database = test_support::routeDatabase(vectors, automatic);
  for (const size_t q : {600u, 650u, 799u}) {
    const QueryResult result = database.query(vectors[q], 1e9, searchWith(automatic));
    EXPECT_TRUE(result.approximate);
    ASSERT_FALSE(result.candidates.empty());
    EXPECT_EQ(result.candidates.front().id, q);
  }
}

TEST(RowProjection, TheProjectionsHonourTheExclusionWindowsAndStopWhereTheGraphTakesOver) {
  std::mt19937 random(17);
  const auto vectors = test_support::routeVectors(700, 64, &random);
  IndexOptions automatic;
  automatic.coarse_from = 500;
  automatic.coarse_candidates = 50;
  automatic.approximate_from = 650;
  std::vector<std::vector<float>> first(vectors.begin(), vectors.begin() + 600);
  const KeyframeDatabase database = test_support::routeDatabase(first, automatic);
  DatabaseOptions options = searchWith(automatic);
  options.exclude_recent_keyframes = 50;   // ids 550..599
  options.exclude_recent_seconds = 100.0;  // stamps within 100 s of 620: ids 521..599
  const QueryResult result = database.query(vectors[599], 620.0, options);
  EXPECT_TRUE(result.approximate);
  EXPECT_EQ(result.searched, 521u);
  ASSERT_EQ(result.candidates.size(), 10u);
  for (const Candidate& c : result.candidates) EXPECT_LE(c.id, 520u);
  options.index.type = "exact";
  const QueryResult expected = database.query(vectors[599], 620.0, options);
  EXPECT_FALSE(expected.approximate);
  EXPECT_EQ(result.candidates.front().id, expected.candidates.front().id);

  // Below coarse_from every keyframe is scored exactly; past approximate_from the graph searches.
  const std::vector<std::vector<float>> small(vectors.begin(), vectors.begin() + 400);
  EXPECT_FALSE(test_support::routeDatabase(small, automatic)
                   .query(vectors[5], 1e9, searchWith(automatic))
                   .approximate);
  const KeyframeDatabase large = test_support::routeDatabase(vectors, automatic);
  const QueryResult through_graph = large.query(vectors[5], 1e9, searchWith(automatic));
  EXPECT_TRUE(through_graph.approximate);
  EXPECT_EQ(through_graph.candidates.front().id, 5u);
  // With the default coarse_from (5 000) this map of 600 is scored exactly.
  IndexOptions off = automatic;
  off.coarse_from = IndexOptions{}.coarse_from;
  EXPECT_FALSE(
      test_support::routeDatabase(first, off).query(vectors[5], 1e9, searchWith(off)).approximate);
}

TEST(RowProjection, ASavedMapIsProjectedAsItIsOpened) {
  std::mt19937 random(19);
  const auto vectors = test_support::routeVectors(300, 32, &random);
  IndexOptions automatic;
  automatic.coarse_from = 100;
  automatic.coarse_candidates = 40;
  const KeyframeDatabase written = test_support::routeDatabase(vectors, automatic);
  // The rows as a map file holds them, adopted without a copy.
  auto rows = std::make_shared<std::vector<uint8_t>>();
  for (const auto& vector : vectors) {
    const std::vector<uint8_t> row = QuantizedVectors::encode(vector);
    rows->insert(rows->end(), row.begin(), row.end());
  }
  KeyframeDatabase opened(32, automatic);
  opened.addSaved(rows, rows->data(), vectors.size(), [](size_t row) {
    KeyframeSummary summary;
    summary.id = row;
    summary.stamp = static_cast<double>(row);
    return summary;
  });
  for (const size_t q : {3u, 150u, 299u}) {
    const QueryResult a = written.query(vectors[q], 1e9, searchWith(automatic));
    const QueryResult b = opened.query(vectors[q], 1e9, searchWith(automatic));
    EXPECT_TRUE(b.approximate);
    ASSERT_EQ(a.candidates.size(), b.candidates.size());
    for (size_t i = 0; i < a.candidates.size(); ++i) {
      EXPECT_EQ(a.candidates[i].id, b.candidates[i].id);
      EXPECT_FLOAT_EQ(a.candidates[i].global_score, b.candidates[i].global_score);
    }
  }
}

}  // namespace landmark_loop_closure
