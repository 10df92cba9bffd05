#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <random>
#include <set>

#include "landmark_loop_closure/database/approximate_index.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "random_descriptors.h"

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

TEST(QuantizedVectors, TheProductIsTheExactIntegerSumAtEveryLength) {
  // Lengths around the 32-value steps of the vector product, and the backbone's 4320.
  std::mt19937 random(11);
  std::uniform_real_distribution<float> value(-1.0f, 1.0f);
  for (const int dimension : {1, 7, 31, 32, 33, 64, 95, 1152, 4320}) {
    std::vector<float> a(static_cast<size_t>(dimension)), b(a.size());
    for (size_t i = 0; i < a.size(); ++i) {
      a[i] = value(random);
      b[i] = i % 5 == 0 ? -value(random) : value(random);
    }
    a[0] = -1.0f;  // -127 after encoding: the extremes are in.
    b[0] = 1.0f;
    const std::vector<uint8_t> x = QuantizedVectors::encode(a);
    const std::vector<uint8_t> y = QuantizedVectors::encode(b);
    float scale_x = 0.0f, scale_y = 0.0f;
    std::memcpy(&scale_x, x.data(), sizeof(float));
    std::memcpy(&scale_y, y.data(), sizeof(float));
    int64_t sum = 0;
    for (int i = 0; i < dimension; ++i) {
      sum += static_cast<int8_t>(x[sizeof(float) + i]) * static_cast<int8_t>(y[sizeof(float) + i]);
    }
    EXPECT_EQ(QuantizedVectors::dot(x.data(), y.data(), dimension),
              scale_x * scale_y * static_cast<float>(sum))
        << dimension;
  }
}

// A graph built in the background reads a snapshot of the first rows while the database grows:
// adopted rows (a mapped rows file) are shared, the rest copied, and the graph built over the
// snapshot searches the database's own rows once rebound.
TEST(QuantizedVectors, ASnapshotSharesAdoptedRowsAndAGraphOverItServesTheOriginal) {
  constexpr int kDim = 8;
  const size_t adopted = 2148;  // Two whole chunks of 1024 rows shared, the rest copied.
  const size_t row_bytes = QuantizedVectors(kDim).rowBytes();
  auto file = std::make_shared<std::vector<uint8_t>>(adopted * row_bytes);
  std::mt19937 random(5);
  std::normal_distribution<float> normal;
  for (size_t row = 0; row < adopted; ++row) {
    std::vector<float> vector(kDim);
    for (float& value : vector) value = normal(random);
    QuantizedVectors::encode(vector.data(), kDim, file->data() + row * row_bytes);
  }
  QuantizedVectors vectors(kDim);
  vectors.adopt(file, file->data(), adopted, row_bytes);
  const std::unique_ptr<QuantizedVectors> snapshot = vectors.snapshot(adopted);
  ASSERT_EQ(snapshot->size(), adopted);
  EXPECT_EQ(snapshot->row(5), vectors.row(5)) << "an adopted row is shared, not copied";
  EXPECT_NE(snapshot->row(adopted - 1), vectors.row(adopted - 1)) << "an owned row is copied";
  EXPECT_EQ(std::memcmp(snapshot->row(adopted - 1), vectors.row(adopted - 1), row_bytes), 0);
  EXPECT_THROW(vectors.snapshot(adopted + 1), std::invalid_argument);

  ApproximateIndex graph(snapshot.get(), 8, 64);
  while (graph.size() < snapshot->size()) graph.add();
  const std::vector<float> extra(kDim, 100.0f);  // Its own best match by inner product.
  vectors.append(extra.data());                  // The database grows after the snapshot.
  EXPECT_THROW(graph.rebind(snapshot->snapshot(10).get()), std::invalid_argument);
  graph.rebind(&vectors);
  graph.add();  // Links the row added since, read from the database's own vectors.
  const auto found = graph.search(vectors.row(adopted), 1, 64);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].first, adopted);
}

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
  EXPECT_EQ(database.summary(0).id, 5u);
}

TEST(KeyframeDatabase, FindsById) {
  KeyframeDatabase database(2);
  for (uint64_t id : {2u, 4u, 9u}) database.add(keyframe(id, id, 0.0));
  ASSERT_NE(database.findSummary(4), nullptr);
  EXPECT_EQ(database.findSummary(4)->stamp, 4.0);
  EXPECT_EQ(database.findSummary(5), nullptr);
  EXPECT_EQ(database.findSummary(100), nullptr);
  EXPECT_GT(database.bytes(), 3 * 2 * sizeof(float));
}

TEST(KeyframeDatabase, RecordsTheMapFileCouldNotTakeStayInMemory) {
  KeyframeDatabase database(2);
  // A map file that has no record at all (as after a full disk): the cache holds two records.
  database.readRecordsFrom([](uint64_t) { return std::optional<KeyframeRecord>(); }, 2);
  database.add(keyframe(1, 1.0, 0.0));
  database.addUnstored(keyframe(2, 2.0, 0.1));
  for (uint64_t id = 3; id < 10; ++id) database.add(keyframe(id, id, 0.2 * id));
  EXPECT_EQ(database.record(0), nullptr) << "left the cache: read from the file, not there";
  ASSERT_NE(database.record(1), nullptr) << "not in the file: kept";
  EXPECT_EQ(database.record(1)->id, 2u);
  EXPECT_NE(database.record(8), nullptr) << "the newest, still cached";
}

TEST(DatabaseOptions, ValidateNamesTheKey) {
  EXPECT_EQ(DatabaseOptions{}.validate(), "");
  DatabaseOptions options;
  options.top_k = 0;
  EXPECT_NE(options.validate().find("advanced/database/top_k"), std::string::npos);
}

TEST(KeyframeDatabase, TheGraphFindsWhatExactSearchFinds) {
  std::mt19937 random(3);
  const auto vectors = test_support::routeVectors(3000, 64, &random);
  IndexOptions approximate;
  approximate.type = "approximate";
  IndexOptions exact;
  exact.type = "exact";
  const KeyframeDatabase graph = test_support::routeDatabase(vectors, approximate);
  const KeyframeDatabase plain = test_support::routeDatabase(vectors, exact);
  ASSERT_NE(graph.graph(), nullptr);
  EXPECT_EQ(plain.graph(), nullptr);
  EXPECT_GT(graph.bytes(), plain.bytes());

  DatabaseOptions options = noExclusion();
  options.top_k = 10;
  options.index = approximate;
  std::normal_distribution<float> noise(0.0f, 0.05f);
  int shared = 0;
  int best_same = 0;
  const int queries = 100;
  for (int q = 0; q < queries; ++q) {
    std::vector<float> query = vectors[static_cast<size_t>(q * 29)];
    for (float& v : query) v += noise(random);
    double norm = 0.0;
    for (float v : query) norm += static_cast<double>(v) * v;
    for (float& v : query) v = static_cast<float>(v / std::sqrt(norm));
    const QueryResult a = graph.query(query, 1e9, options);
    const QueryResult b = plain.query(query, 1e9, options);
    EXPECT_TRUE(a.approximate);
    EXPECT_FALSE(b.approximate);
    ASSERT_EQ(a.candidates.size(), 10u);
    std::set<uint64_t> exact_ids;
    for (const Candidate& c : b.candidates) exact_ids.insert(c.id);
    for (const Candidate& c : a.candidates) shared += static_cast<int>(exact_ids.count(c.id));
    best_same += a.candidates.front().id == b.candidates.front().id;
    // Scores are the same 8-bit cosine either way, within 0.01 of the float one.
    EXPECT_NEAR(a.candidates.front().global_score,
                graph.similarity(query, a.candidates.front().index), 1e-6);
    EXPECT_NEAR(a.candidates.front().global_score,
                cosineSimilarity(query, vectors[a.candidates.front().id]), 0.01);
  }
  EXPECT_GE(shared, queries * 10 * 95 / 100);
  EXPECT_GE(best_same, queries * 98 / 100);
}

TEST(KeyframeDatabase, TheGraphHonoursBothExclusionWindows) {
  std::mt19937 random(5);
  const auto vectors = test_support::routeVectors(500, 32, &random);
  IndexOptions approximate;
  approximate.type = "approximate";
  const KeyframeDatabase database = test_support::routeDatabase(vectors, approximate);
  DatabaseOptions options = noExclusion();
  options.index = approximate;
  options.top_k = 5;
  options.exclude_recent_keyframes = 50;   // ids 450..499
  options.exclude_recent_seconds = 100.0;  // stamps within 100 s of 520: ids 421..499
  // The query is the newest keyframe: its nearest neighbours are all excluded.
  const QueryResult result = database.query(vectors.back(), 520.0, options);
  EXPECT_TRUE(result.approximate);
  EXPECT_EQ(result.searched, 421u);
  ASSERT_EQ(result.candidates.size(), 5u);
  for (const Candidate& c : result.candidates) EXPECT_LE(c.id, 420u);
  options.index.type = "exact";
  const QueryResult expected = database.query(vectors.back(), 520.0, options);
  EXPECT_FALSE(expected.approximate);
  EXPECT_EQ(result.candidates.front().id, expected.candidates.front().id);
}

TEST(KeyframeDatabase, AutoSearchesExactlyUntilTheDatabaseIsLarge) {
  std::mt19937 random(9);
  const auto vectors = test_support::routeVectors(120, 16, &random);
  IndexOptions automatic;
  automatic.approximate_from = 100;
  const std::vector<std::vector<float>> first(vectors.begin(), vectors.begin() + 99);
  DatabaseOptions options = noExclusion();
  options.index = automatic;
  const KeyframeDatabase small = test_support::routeDatabase(first, automatic);
  ASSERT_NE(small.graph(), nullptr);  // Kept up to date all along, so switching costs nothing.
  EXPECT_FALSE(small.query(vectors[5], 1e9, options).approximate);
  const KeyframeDatabase large = test_support::routeDatabase(vectors, automatic);
  EXPECT_TRUE(large.query(vectors[5], 1e9, options).approximate);
  EXPECT_EQ(large.query(vectors[5], 1e9, options).candidates.front().id, 5u);
}

TEST(KeyframeDatabase, SetIndexBuildsOrDropsTheGraphAndRefusesAWrongOne) {
  std::mt19937 random(11);
  const auto vectors = test_support::routeVectors(50, 8, &random);
  IndexOptions exact;
  exact.type = "exact";
  KeyframeDatabase database = test_support::routeDatabase(vectors, exact);
  EXPECT_EQ(database.graph(), nullptr);
  database.setIndex(IndexOptions{});
  ASSERT_NE(database.graph(), nullptr);
  EXPECT_EQ(database.graph()->size(), 50u);
  // A graph over other vectors, and one holding more keyframes than the database.
  QuantizedVectors other(8);
  EXPECT_THROW(
      database.setIndex(IndexOptions{}, std::make_unique<ApproximateIndex>(&other, 16, 64)),
      std::invalid_argument);
  KeyframeDatabase larger =
      test_support::routeDatabase(test_support::routeVectors(60, 8, &random), IndexOptions{});
  EXPECT_THROW(database.setIndex(IndexOptions{},
                                 std::make_unique<ApproximateIndex>(larger.vectors(), 16, 64)),
               std::invalid_argument);
  EXPECT_NE(database.graph(), nullptr);  // Unchanged by the refused call.
  IndexOptions bad;
  bad.type = "fast";
  EXPECT_THROW(database.setIndex(bad), std::invalid_argument);
  database.setIndex(exact);
  EXPECT_EQ(database.graph(), nullptr);
}

TEST(KeyframeDatabase, AQueryOfTheWrongLengthIsRefused) {
  KeyframeDatabase database(2);
  database.add(keyframe(1, 1.0, 0.0));
  EXPECT_THROW(database.query({1.0f, 0.0f, 0.0f}, 100.0, noExclusion()), std::invalid_argument);
}

TEST(IndexOptions, ValidateNamesTheKey) {
  IndexOptions options;
  EXPECT_EQ(options.validate(), "");
  options.type = "fast";
  options.neighbors = 2;
  options.ef_search = 0;
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("advanced/database/index/type"), std::string::npos);
  EXPECT_NE(errors.find("advanced/database/index/neighbors"), std::string::npos);
  EXPECT_NE(errors.find("advanced/database/index/ef_search"), std::string::npos);
}
