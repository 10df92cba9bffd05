// Count sketches of the database's rows, and the search of a large map through them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/row_sketches.h"
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

TEST(RowSketches, TheirProductEstimatesTheRowsProduct) {
  const int dimension = 4320;
  std::mt19937 random(11);
  std::normal_distribution<float> normal;
  RowSketches sketches(dimension);
  // Pairs of unit vectors whose cosine is about 0, 0.5 and 0.9.
  for (const float shared : {0.0f, 0.5f, 0.9f}) {
    double error_sum = 0.0;
    double squared_error_sum = 0.0;
    const int pairs = 200;
    for (int p = 0; p < pairs; ++p) {
      std::vector<float> common(dimension);
      std::vector<float> a(dimension);
      std::vector<float> b(dimension);
      for (int i = 0; i < dimension; ++i) {
        common[i] = normal(random);
        a[i] = std::sqrt(shared) * common[i] + std::sqrt(1.0f - shared) * normal(random);
        b[i] = std::sqrt(shared) * common[i] + std::sqrt(1.0f - shared) * normal(random);
      }
      const std::vector<uint8_t> row_a = QuantizedVectors::encode(unit(a));
      const std::vector<uint8_t> row_b = QuantizedVectors::encode(unit(b));
      const float exact = QuantizedVectors::dot(row_a.data(), row_b.data(), dimension);
      const std::vector<uint8_t> sketch_a = sketches.sketch(row_a.data());
      const std::vector<uint8_t> sketch_b = sketches.sketch(row_b.data());
      const float estimate =
          QuantizedVectors::dot(sketch_a.data(), sketch_b.data(), RowSketches::kDimension);
      error_sum += estimate - exact;
      squared_error_sum += (estimate - exact) * (estimate - exact);
    }
    // Unbiased, with an error of about sqrt((1 + cosine^2) / 256).
    const double bias = error_sum / pairs;
    const double spread = std::sqrt(squared_error_sum / pairs);
    EXPECT_LT(std::abs(bias), 0.02) << "cosine " << shared;
    EXPECT_LT(spread, 1.5 * std::sqrt((1.0 + shared * shared) / RowSketches::kDimension))
        << "cosine " << shared;
  }
}

TEST(RowSketches, ALargeMapSearchedThroughThemFindsWhatExactSearchFinds) {
  std::mt19937 random(13);
  const auto vectors = test_support::routeVectors(6000, 512, &random);
  IndexOptions automatic;
  automatic.coarse_from = 5000;  // The sketches search this map.
  IndexOptions exact;
  exact.type = "exact";
  const KeyframeDatabase sketched = test_support::routeDatabase(vectors, automatic);
  const KeyframeDatabase plain = test_support::routeDatabase(vectors, exact);
  EXPECT_GT(sketched.bytes(), plain.bytes());
  std::normal_distribution<float> noise(0.0f, 0.03f);
  size_t shared = 0;
  size_t wanted = 0;
  for (int q = 0; q < 100; ++q) {
    std::vector<float> query = vectors[static_cast<size_t>(q * 59)];
    for (float& v : query) v += noise(random);
    query = unit(query);
    const QueryResult coarse = sketched.query(query, 1e9, searchWith(automatic));
    const QueryResult every = plain.query(query, 1e9, searchWith(exact));
    EXPECT_TRUE(coarse.approximate);
    EXPECT_FALSE(every.approximate);
    ASSERT_EQ(coarse.candidates.size(), 10u);
    std::set<uint64_t> exact_ids;
    for (const Candidate& c : every.candidates) exact_ids.insert(c.id);
    for (const Candidate& c : coarse.candidates) {
      shared += exact_ids.count(c.id);
      // A candidate's score is its exact one, and its id the keyframe's.
      EXPECT_FLOAT_EQ(c.global_score, sketched.similarity(query, c.index));
      EXPECT_EQ(c.id, c.index);
    }
    wanted += exact_ids.size();
  }
  EXPECT_GE(shared, wanted * 99 / 100);
}

TEST(RowSketches, TheSketchesHonourTheExclusionWindowsAndStopWhereTheGraphTakesOver) {
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
  // With coarse_from 0 (the default) a map of any size is scored exactly below approximate_from.
  IndexOptions off = automatic;
  off.coarse_from = IndexOptions{}.coarse_from;
  EXPECT_FALSE(
      test_support::routeDatabase(first, off).query(vectors[5], 1e9, searchWith(off)).approximate);
}

TEST(RowSketches, ASavedMapIsSketchedAsItIsOpened) {
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
