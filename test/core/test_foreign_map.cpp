// Another robot's large map searched through its graph (issue 81): the rows read are those near
// the run's keyframes and a fixed sample, far fewer than the map's, and the search finds what
// reading every row finds.
#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"
#include "landmark_loop_closure/fleet/foreign_map.h"

namespace landmark_loop_closure {
namespace {

constexpr int kDimension = 64;
const std::string kIdentity = "test descriptor";

std::vector<float> normalised(std::vector<float> vector) {
  double norm = 0.0;
  for (const float value : vector) norm += static_cast<double>(value) * value;
  for (float& value : vector) value = static_cast<float>(value / std::sqrt(norm));
  return vector;
}

/// A route's look, keyframe after keyframe: each a small random step from the last, so that a
/// place looks like its neighbours and unlike places tens of keyframes away.
std::vector<std::vector<float>> route(size_t keyframes, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<float> step(0.0f, 0.35f);
  std::vector<float> look(kDimension);
  for (float& value : look) value = step(random);
  std::vector<std::vector<float>> looks;
  for (size_t k = 0; k < keyframes; ++k) {
    for (float& value : look) value += step(random);
    look = normalised(look);
    looks.push_back(look);
  }
  return looks;
}

/// `look` as another camera sees it: noise of its own.
std::vector<float> seenAgain(const std::vector<float>& look, std::mt19937* random) {
  std::normal_distribution<float> noise(0.0f, 0.12f);
  std::vector<float> seen = look;
  for (float& value : seen) value += noise(*random);
  return normalised(seen);
}

SharedKeyframe rowOf(const std::string& robot, uint64_t map_id, uint64_t id,
                     const std::vector<float>& look) {
  SharedKeyframe shared;
  shared.robot = robot;
  shared.map_id = map_id;
  shared.id = id;
  shared.stamp_ns = static_cast<int64_t>(id + 1) * 100000000;
  shared.pose.position.x() = 2.0 * static_cast<double>(id);
  shared.odometry_frame = robot + "/odom";
  shared.descriptor_fingerprint = descriptorFingerprint(kIdentity);
  shared.global_row = QuantizedVectors::encode(look);
  return shared;
}

struct Scored {
  std::optional<size_t> best;
  double best_score = -HUGE_VAL;
  size_t read = 0;
  MapScores scores;
};

/// The run's path scores over `map`, newest keyframe first in `rows`.
Scored scoreRun(const ForeignMap& map, const std::vector<std::vector<uint8_t>>& rows,
                std::vector<KeyframeCosines>* cosines, const std::vector<double>& speeds) {
  std::vector<QueryKeyframe> run;
  for (size_t i = 0; i < rows.size(); ++i) run.push_back({rows[i].data(), &(*cosines)[i]});
  Scored result;
  result.scores = map.score(run, speeds);
  for (const ScoredRow& row : result.scores.rows) {
    if (row.score > result.best_score) {
      result.best_score = row.score;
      result.best = row.position;
    }
  }
  for (const KeyframeCosines& keyframe : *cosines) {
    result.read += keyframe.computed;
  }
  return result;
}

TEST(ForeignMap, ALargeMapIsReadAtItsNearestRowsAndASampleAndFindsTheSameBest) {
  const size_t rows = 8000;
  const std::vector<std::vector<float>> looks = route(rows, 7);
  ForeignSearchOptions exact_search;
  exact_search.approximate_from = 0;
  ForeignSearchOptions graph_search;
  graph_search.approximate_from = 1000;
  ForeignMap exact("a", "a", 1, kDimension, exact_search);
  ForeignMap graph("a", "a", 1, kDimension, graph_search);
  for (uint64_t id = 0; id < rows; ++id) {
    exact.add(rowOf("a", 1, id, looks[id]));
    graph.add(rowOf("a", 1, id, looks[id]));
  }
  SequenceMatchingOptions sequence;
  const std::vector<double> speeds = sequence.speeds();
  const size_t length = static_cast<size_t>(sequence.length);
  std::mt19937 random(11);
  size_t same = 0;
  size_t queries = 0;
  size_t most_read = 0;
  // Robot b drives three stretches of a's route; each keyframe's run is its last `length`.
  for (const size_t start : {300u, 4100u, 7400u}) {
    std::vector<std::vector<uint8_t>> run_rows;
    std::vector<KeyframeCosines> exact_cosines, graph_cosines;
    for (size_t k = 0; k < 40; ++k) {
      run_rows.insert(run_rows.begin(),
                      QuantizedVectors::encode(seenAgain(looks[start + k], &random)));
      exact_cosines.insert(exact_cosines.begin(), KeyframeCosines{});
      graph_cosines.insert(graph_cosines.begin(), KeyframeCosines{});
      if (run_rows.size() > length) {
        run_rows.pop_back();
        exact_cosines.pop_back();
        graph_cosines.pop_back();
      }
      if (run_rows.size() < length) continue;
      const Scored everything = scoreRun(exact, run_rows, &exact_cosines, speeds);
      const Scored nearest = scoreRun(graph, run_rows, &graph_cosines, speeds);
      ASSERT_TRUE(everything.best);
      ASSERT_TRUE(nearest.best);
      EXPECT_FALSE(everything.scores.approximate);
      EXPECT_TRUE(nearest.scores.approximate);
      EXPECT_GT(everything.scores.rows.size(), rows - length * 2);  // Every row with a path.
      ++queries;
      if (*nearest.best == *everything.best) ++same;
      EXPECT_NEAR(nearest.best_score, everything.best_score, 1e-9);
      // What a row scores does not depend on how the rows were read.
      for (const ScoredRow& row : nearest.scores.rows) {
        const auto found =
            std::find_if(everything.scores.rows.begin(), everything.scores.rows.end(),
                         [&](const ScoredRow& other) { return other.position == row.position; });
        if (found == everything.scores.rows.end()) continue;
        ASSERT_DOUBLE_EQ(row.score, found->score);
      }
      most_read = std::max(most_read, nearest.read);
    }
  }
  EXPECT_EQ(same, queries) << "the best path found through the graph is the exact search's";
  // The sample (at most 32 blocks of 32) plus the paths through the nearest rows, over the
  // keyframes of the run; exact search reads every row for each of them.
  EXPECT_LT(most_read, rows * length / 6) << most_read << " cosines held";
  std::printf("cosines held over the run: at most %zu (every row: %zu)\n", most_read,
              rows * length);
}

TEST(ForeignMap, ASmallMapIsReadWholeAndEveryRowIsEvidence) {
  const std::vector<std::vector<float>> looks = route(300, 3);
  ForeignMap map("a", "a", 1, kDimension, ForeignSearchOptions{});
  for (uint64_t id = 0; id < looks.size(); ++id) map.add(rowOf("a", 1, id, looks[id]));
  std::vector<std::vector<uint8_t>> run_rows = {QuantizedVectors::encode(looks[100])};
  std::vector<KeyframeCosines> cosines(1);
  const Scored scored = scoreRun(map, run_rows, &cosines, {1.0});
  EXPECT_FALSE(scored.scores.approximate);
  EXPECT_EQ(scored.scores.rows.size(), looks.size());
  EXPECT_EQ(scored.scores.rows_per_sample, 1.0);
  for (const ScoredRow& row : scored.scores.rows) EXPECT_TRUE(row.sampled);
  EXPECT_EQ(scored.best, 100u);
}

// Through the fleet matcher: robot b's stretches of a large map of robot a get the candidates
// reading every row gets, from a sample for the calibrated decision's tail.
TEST(FleetMatcher, ALargeMapGivesTheCandidatesReadingEveryRowGives) {
  const size_t rows = 6000;
  const std::vector<std::vector<float>> looks = route(rows, 5);
  FleetOptions exact_options;
  exact_options.approximate_from = 0;
  FleetOptions graph_options;
  graph_options.approximate_from = 1000;
  FleetMatcher exact(exact_options, kIdentity, kDimension);
  FleetMatcher graph(graph_options, kIdentity, kDimension);
  for (uint64_t id = 0; id < rows; ++id) {
    EXPECT_EQ(exact.addRow(rowOf("a", 1, id, looks[id]), 0.0, 2), "");
    EXPECT_EQ(graph.addRow(rowOf("a", 1, id, looks[id]), 0.0, 2), "");
  }
  std::mt19937 random(13);
  size_t exact_found = 0, graph_found = 0, agree = 0, keyframes = 0;
  uint64_t own_id = 0;
  uint32_t session = 0;
  // Each stretch a session of its own: its paths do not run on from the last stretch's end.
  for (const size_t start : {200u, 2500u, 5100u}) {
    for (size_t k = 0; k < 60; ++k, ++own_id) {
      SharedKeyframe own = rowOf("b", 2, own_id, seenAgain(looks[start + k], &random));
      own.session = session;
      const std::optional<FleetCandidate> by_all = exact.query(own);
      const std::optional<FleetCandidate> by_graph = graph.query(own);
      ++keyframes;
      exact_found += by_all.has_value();
      graph_found += by_graph.has_value();
      if (by_all.has_value() == by_graph.has_value() &&
          (!by_all || by_all->match.id == by_graph->match.id)) {
        ++agree;
      }
      for (const auto& candidate : {by_all, by_graph}) {
        if (!candidate) continue;
        const int64_t off =
            static_cast<int64_t>(candidate->match.id) - static_cast<int64_t>(start + k);
        EXPECT_LE(std::abs(off), 3) << "keyframe " << own_id;
      }
    }
    ++session;
  }
  EXPECT_GE(exact_found, keyframes / 2);
  EXPECT_GE(graph_found, exact_found * 95 / 100);
  EXPECT_GE(agree, keyframes * 95 / 100) << agree << " of " << keyframes;
  std::printf("candidates: every row %zu, graph and sample %zu, the same %zu of %zu keyframes\n",
              exact_found, graph_found, agree, keyframes);
}

}  // namespace
}  // namespace landmark_loop_closure
