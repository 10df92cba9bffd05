#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/false_alarms.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "random_descriptors.h"
#include "small_detector.h"

using namespace landmark_loop_closure;

TEST(ScoreTail, TooFewScoresCalibrateNothing) {
  const ScoreTail tail = fitScoreTail(std::vector<double>(ScoreTail::kMinSamples - 1, 0.1));
  EXPECT_FALSE(tail.valid());
  EXPECT_DOUBLE_EQ(tail.exceedance(0.99), 1.0);
  EXPECT_TRUE(std::isinf(tail.scoreFor(0.1, 100)));
}

TEST(ScoreTail, RecoversAnExponentialTail) {
  // Scores 0.1 + Exp(mean 0.05): above any threshold inside the sample, the excess is again
  // exponential with mean 0.05.
  std::mt19937 random(7);
  std::exponential_distribution<double> excess(1.0 / 0.05);
  std::vector<double> scores;
  for (int i = 0; i < 20000; ++i) scores.push_back(0.1 + excess(random));
  const ScoreTail tail = fitScoreTail(scores, 0.1);
  ASSERT_TRUE(tail.valid());
  EXPECT_NEAR(tail.tail_fraction, 0.1, 1e-9);
  EXPECT_NEAR(tail.mean_excess, 0.05, 0.003);
  // The 90th percentile of 0.1 + Exp(0.05) is 0.1 + 0.05 ln 10.
  EXPECT_NEAR(tail.threshold, 0.1 + 0.05 * std::log(10.0), 0.005);
  // P(S >= 0.1 + 0.05 ln 1000) = 1e-3 exactly under the model.
  EXPECT_NEAR(tail.exceedance(0.1 + 0.05 * std::log(1000.0)), 1e-3, 2e-4);
}

TEST(ScoreTail, ExpectedFalseAlarmsAndTheScoreForThemAgree) {
  std::vector<double> scores;
  for (int i = 0; i < 200; ++i) scores.push_back(0.001 * i);
  const ScoreTail tail = fitScoreTail(scores);
  for (const double bound : {0.01, 0.1, 1.0}) {
    const double score = tail.scoreFor(bound, 5000);
    EXPECT_NEAR(tail.expectedFalseAlarms(score, 5000), bound, 1e-9 * bound);
  }
  // More places searched: the same bound needs a higher score.
  EXPECT_GT(tail.scoreFor(0.1, 50000), tail.scoreFor(0.1, 5000));
  // At or below the tail's threshold, a score is as common as the tail itself.
  EXPECT_DOUBLE_EQ(tail.exceedance(tail.threshold), 1.0);
}

TEST(ScoreTail, EqualScoresStillLeaveAMargin) {
  // Every other place scores exactly 0.3: a score just above must not count as impossible.
  const ScoreTail tail = fitScoreTail(std::vector<double>(100, 0.3));
  ASSERT_TRUE(tail.valid());
  EXPECT_DOUBLE_EQ(tail.mean_excess, ScoreTail::kMinMeanExcess);
  EXPECT_GT(tail.expectedFalseAlarms(0.31, 100), 1.0);
  EXPECT_LT(tail.expectedFalseAlarms(0.5, 100), 1e-6);
}

TEST(ScoreTail, AHeavierTailNeedsAHigherScore) {
  // A varied route (other places 0.0-0.1) against look-alike bays (the same range and a third of
  // the places up to 0.4): the same bound asks more of the second.
  std::vector<double> varied;
  std::vector<double> bays;
  for (int i = 0; i < 300; ++i) {
    varied.push_back(0.1 * (i % 100) / 100.0);
    bays.push_back(i % 3 == 0 ? 0.4 * (i % 100) / 100.0 : 0.1 * (i % 100) / 100.0);
  }
  const ScoreTail varied_tail = fitScoreTail(varied);
  const ScoreTail bay_tail = fitScoreTail(bays);
  EXPECT_LT(varied_tail.scoreFor(0.1, 300), 0.25);
  EXPECT_GT(bay_tail.scoreFor(0.1, 300), 0.45);
}

TEST(PassedPlaceScores, CalibratesOnceEnoughScoresArePooledAndKeepsTheLastQueries) {
  PassedPlaceScores passed;
  EXPECT_FALSE(passed.tail().valid());
  for (int query = 0; query < 9; ++query) passed.add(std::vector<double>(20, 0.1 + 0.01 * query));
  EXPECT_EQ(passed.samples(), 180u);
  EXPECT_FALSE(passed.tail().valid()) << "under kMinSamples: nothing to calibrate on yet";
  passed.add(std::vector<double>(20, 0.5));
  ASSERT_TRUE(passed.tail().valid());
  // The top 10 % (20 scores) is the last query's 0.5; the threshold is the next score down.
  EXPECT_NEAR(passed.tail().threshold, 0.18, 1e-12);
  EXPECT_NEAR(passed.tail().mean_excess, 0.32, 1e-12);
  // Only the last kQueries queries count: a stretch left long ago is forgotten.
  for (size_t query = 0; query < PassedPlaceScores::kQueries; ++query) {
    passed.add(std::vector<double>(1, 0.2));
  }
  EXPECT_EQ(passed.samples(), PassedPlaceScores::kQueries);
  EXPECT_DOUBLE_EQ(passed.tail().threshold, 0.2);
  passed.add({});
  EXPECT_EQ(passed.samples(), PassedPlaceScores::kQueries) << "an empty query adds nothing";
  passed.clear();
  EXPECT_EQ(passed.samples(), 0u);
}

namespace {

// Places as vectors: image pixel (0,0) names the place, (0,1) the world (0: every place its own
// look; 1: bays, every fourth place built from the same look with its own share; 2: a slow
// stretch, each frame the sum of the last kStretch + 1 of a series of looks, so frames 13 apart
// still share 60 % of it), (0,2) = 1 a revisit under other light (half the vector replaced:
// cosine about 0.7 with the first visit).
class WorldExtractor : public DescriptorExtractor {
 public:
  /// 64 dimensions: random places score 0 +- 0.125 against each other; 256: +- 0.06.
  explicit WorldExtractor(int dimension = 64) : dimension_(dimension) {}
  std::string name() const override { return "world"; }
  int globalDimension() const override { return dimension_; }
  ImageDescriptor describe(const cv::Mat& image) const override {
    const int place = image.at<uchar>(0, 0);
    const bool bays = image.at<uchar>(0, 1) == 1;
    const bool stretch = image.at<uchar>(0, 1) == 2;
    const bool revisit = image.at<uchar>(0, 2) == 1;
    std::vector<float> look = randomVector(place);
    if (stretch) {
      look.assign(dimension_, 0.0f);
      for (int k = place - kStretch; k <= place; ++k) {
        const std::vector<float> part = randomVector(3000 + k);
        for (int i = 0; i < dimension_; ++i) look[i] += part[i];
      }
    }
    if (bays) {
      const std::vector<float> bay = randomVector(1000 + place % 4);
      const float own = 0.35f + 0.1f * static_cast<float>(place % 7);
      for (int i = 0; i < dimension_; ++i) look[i] = bay[i] + own * look[i];
    }
    normalise(&look);
    if (revisit) {
      const std::vector<float> light = randomVector(2000 + place);
      for (int i = 0; i < dimension_; ++i) look[i] += light[i];
      normalise(&look);
    }
    ImageDescriptor descriptor;
    descriptor.global = look;
    return descriptor;
  }

 private:
  int dimension_;
  static constexpr int kStretch = 30;
  std::vector<float> randomVector(int seed) const {
    std::mt19937 random(static_cast<uint32_t>(seed) * 7919u + 13u);
    std::normal_distribution<float> normal;
    std::vector<float> v(dimension_);
    for (float& x : v) x = normal(random);
    normalise(&v);
    return v;
  }
  static void normalise(std::vector<float>* v) {
    double norm = 0.0;
    for (const float x : *v) norm += x * x;
    for (float& x : *v) x = static_cast<float>(x / std::sqrt(norm));
  }
};

cv::Mat worldImage(int place, bool bays, bool revisit, bool stretch = false) {
  cv::Mat image = test_support::place(place);
  image.at<uchar>(0, 1) = stretch ? 2 : bays ? 1 : 0;
  image.at<uchar>(0, 2) = revisit ? 1 : 0;
  return image;
}

// Maps 60 places of one world, then revisits places 30-34 under other light; returns the loops
// and the lowest expected false alarms the revisits' best candidates had.
struct Drive {
  int loops = 0;
  double fewest_false_alarms = HUGE_VAL;
};

struct Odometry {
  bool gate = false;          ///< odometry_gate on.
  bool came_back = false;     ///< The revisit's odometry at the places' own poses (else 30 m on).
  double within_reach = 0.0;  ///< advanced/acceptance/max_false_alarms_within_reach.
};

Drive drive(bool bays, double max_false_alarms, const Odometry& odometry = {}) {
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.min_score = 0.3;
  options.acceptance.max_false_alarms = max_false_alarms;
  options.acceptance.max_false_alarms_within_reach = odometry.within_reach;
  options.odometry_gate.enabled = odometry.gate;
  options.acceptance.sequence.length = 1;
  options.acceptance.min_place_ratio = 0.0;
  LoopDetector detector(options, std::make_shared<WorldExtractor>());
  Drive result;
  int frame = 0;
  for (int place = 0; place < 60; ++place, ++frame) {
    detector.process(frame, planarPose(frame, 0, 0), worldImage(place, bays, false));
  }
  if (odometry.came_back) {
    // Round the block, past places never seen before, back to the start of place 30.
    std::vector<Eigen::Vector2d> way;
    for (int y = 1; y <= 5; ++y) way.emplace_back(59, y);
    for (int x = 58; x >= 25; --x) way.emplace_back(x, 5);
    for (int y = 4; y >= 0; --y) way.emplace_back(25, y);
    for (int x = 26; x < 30; ++x) way.emplace_back(x, 0);
    for (size_t i = 0; i < way.size(); ++i, ++frame) {
      detector.process(frame, planarPose(way[i].x(), way[i].y(), 0),
                       worldImage(300 + static_cast<int>(i), bays, false));
    }
  }
  for (int place = 30; place < 35; ++place, ++frame) {
    const double x = odometry.came_back ? place : frame;
    const FrameResult step =
        detector.process(frame, planarPose(x, 0, 0), worldImage(place, bays, true));
    if (!step.keyframe) continue;
    if (step.keyframe->loop) ++result.loops;
    for (const CandidateReport& candidate : step.keyframe->candidates) {
      if (candidate.false_alarms >= 0.0) {
        result.fewest_false_alarms = std::min(result.fewest_false_alarms, candidate.false_alarms);
      }
    }
  }
  return result;
}

}  // namespace

TEST(CalibratedDecision, AbsoluteThresholdAcceptsBothWorlds) {
  // The check the calibrated decision is measured against: one absolute min_score publishes the
  // revisit in the varied world and in the world of bays alike.
  EXPECT_GT(drive(false, 0.0).loops, 0);
  EXPECT_GT(drive(true, 0.0).loops, 0);
}

TEST(CalibratedDecision, TheSameRevisitNeedsMoreAmongLookAlikes) {
  const Drive varied = drive(false, 0.01);
  const Drive bays = drive(true, 0.01);
  // (A revisit in the run that mapped it: the places between left it, as leftThePlace asks.)
  EXPECT_GT(varied.loops, 0) << "a revisit that stands out of a varied map is believed";
  EXPECT_LT(varied.fewest_false_alarms, 0.01);
  EXPECT_EQ(bays.loops, 0) << "among bays that look alike the same revisit is not";
  EXPECT_GT(bays.fewest_false_alarms, 0.01);
}

TEST(CalibratedDecision, ARevisitTheOdometryPutsWithinReachMayNeedLess) {
  // Among bays that look alike the revisit alone is not believed (above), nor with the odometry
  // gate on and no bound of its own.
  const Drive alone = drive(true, 0.01, {true, true, 0.0});
  EXPECT_EQ(alone.loops, 0);
  const double needed = alone.fewest_false_alarms;
  ASSERT_GT(needed, 0.01);
  ASSERT_LT(needed, 1000.0);
  // The odometry brought the robot back there: within its reach the bound of its own applies.
  EXPECT_GT(drive(true, 0.01, {true, true, 2.0 * needed}).loops, 0);
  // The same bound changes nothing where the odometry cannot witness: the gate off (image-only),
  // or the robot 30 m on (the gate refuses it, whatever it scores).
  EXPECT_EQ(drive(true, 0.01, {false, true, 2.0 * needed}).loops, 0);
  EXPECT_EQ(drive(true, 0.01, {true, false, 2.0 * needed}).loops, 0);
}

TEST(CalibratedDecision, ARevisitContinuingThePublishedLoopIsOneOfFewPlaces) {
  // A revisit of 25 places under other light after a varied map: once a keyframe published a
  // loop, the next keyframe's candidate continuing it (within index_window of its match) is
  // counted among the 2 * index_window + 1 places that would continue it, not the whole map's.
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.min_score = 0.3;
  options.acceptance.max_false_alarms = 1e-4;
  options.acceptance.sequence.length = 1;
  options.acceptance.min_place_ratio = 0.0;
  // The next keyframe only: a loop continued across refused keyframes is
  // test_calibrated_decision's.
  options.acceptance.continue_across = 1;
  LoopDetector detector(options, std::make_shared<WorldExtractor>());
  int frame = 0;
  for (int place = 0; place < 60; ++place, ++frame) {
    detector.process(frame, planarPose(frame, 0, 0), worldImage(place, false, false));
  }
  const size_t continuing = 2 * static_cast<size_t>(options.acceptance.index_window) + 1;
  bool last_published = false;
  size_t map_places = 0;  // What the last candidate tested over the map counted.
  int loops = 0;
  int believed_only_as_continuation = 0;
  for (int place = 20; place < 45; ++place, ++frame) {
    const FrameResult step =
        detector.process(frame, planarPose(frame, 0, 0), worldImage(place, false, true));
    ASSERT_TRUE(step.keyframe);
    for (const CandidateReport& candidate : step.keyframe->candidates) {
      if (candidate.false_alarm_places > continuing) map_places = candidate.false_alarm_places;
    }
    for (const CandidateReport& candidate : step.keyframe->candidates) {
      if (candidate.false_alarm_places == 0) continue;
      const bool continues = last_published && static_cast<int>(candidate.match_id) == place;
      if (!last_published) {
        EXPECT_GT(candidate.false_alarm_places, continuing);
      }
      if (continues) {
        EXPECT_EQ(candidate.false_alarm_places, continuing);
        // Over the whole map it would have been refused.
        const double over_the_map = candidate.false_alarms * static_cast<double>(map_places) /
                                    static_cast<double>(continuing);
        if (candidate.verdict == CandidateVerdict::kAccepted && map_places > continuing &&
            over_the_map > options.acceptance.max_false_alarms) {
          ++believed_only_as_continuation;
        }
      }
    }
    last_published = step.keyframe->loop.has_value();
    if (last_published) ++loops;
  }
  EXPECT_GE(loops, 15);
  EXPECT_GT(believed_only_as_continuation, 0);
}

// Maps 60 varied places, then drives a slow stretch of 40 frames of one look drifting: frames
// just beyond the exclusion window still look like the query, the robot never left them.
int slowStretchLoops(double max_false_alarms, std::vector<std::string>* refusals) {
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.min_score = 0.3;
  options.acceptance.max_false_alarms = max_false_alarms;
  options.acceptance.sequence.length = 1;
  options.acceptance.min_place_ratio = 0.0;
  options.acceptance.place_window = 5;
  options.database.exclude_recent_keyframes = 12;
  // 256 dimensions: at 64 a drifting look happens to stay near one random place for a while.
  LoopDetector detector(options, std::make_shared<WorldExtractor>(256));
  int frame = 0;
  for (int place = 0; place < 60; ++place, ++frame) {
    detector.process(frame, planarPose(frame, 0, 0), worldImage(place, false, false));
  }
  int loops = 0;
  for (int step = 0; step < 40; ++step, ++frame) {
    const FrameResult result = detector.process(frame, planarPose(frame, 0, 0),
                                                worldImage(100 + step, false, false, true));
    if (!result.keyframe) continue;
    if (result.keyframe->loop) ++loops;
    for (const CandidateReport& candidate : result.keyframe->candidates) {
      if (candidate.detail.find("places just passed") != std::string::npos ||
          candidate.detail.rfind("not a revisit", 0) == 0) {
        refusals->push_back(candidate.detail);
      }
    }
  }
  return loops;
}

TEST(CalibratedDecision, ASlowStretchOfLookAlikeFramesIsNotARevisit) {
  std::vector<std::string> refusals;
  // The failure it guards against: an absolute threshold believes frames of the stretch just past
  // the exclusion window (they score 0.6 against the query, other places 0.0-0.3).
  EXPECT_GT(slowStretchLoops(0.0, &refusals), 0);
  EXPECT_TRUE(refusals.empty());
  // The calibrated decision: they stand far out of the map's other places. Where the stretch
  // begins, the places between them and the query never looked like an ordinary other place
  // (the query has not left them); further on, they do not stand out of what the places just
  // passed (12 to 24 keyframes back) score against each query.
  EXPECT_EQ(slowStretchLoops(0.01, &refusals), 0);
  ASSERT_FALSE(refusals.empty());
  EXPECT_NE(refusals.front().find("not a revisit: every keyframe of this run since its place"),
            std::string::npos)
      << refusals.front();
  EXPECT_NE(refusals.back().find("of the 12 places just passed expected to score as high"),
            std::string::npos)
      << refusals.back();
}

TEST(CalibratedDecision, OffLeavesEveryCandidateUntested) {
  LoopDetectorOptions options = test_support::smallOptions();
  ASSERT_EQ(options.acceptance.max_false_alarms, 0.0);
  LoopDetector detector(options, std::make_shared<WorldExtractor>());
  for (int frame = 0; frame < 40; ++frame) {
    const FrameResult step =
        detector.process(frame, planarPose(frame, 0, 0), worldImage(frame % 20, false, false));
    if (!step.keyframe) continue;
    for (const CandidateReport& candidate : step.keyframe->candidates) {
      EXPECT_EQ(candidate.false_alarms, -1.0);
    }
  }
}

TEST(ScoreBackground, EachSampledPlaceScoresAsItWouldAsACandidate) {
  // A map larger than the sample: 3000 keyframes, sampled in blocks.
  const int dimension = 32;
  KeyframeDatabase database(dimension);
  test_support::RandomDescriptors descriptors(dimension, 3);
  descriptors.fill(&database, 3000);
  test_support::PlaceExtractor extractor;  // globalScore is the identity.
  SequenceMatchingOptions options;
  options.length = 4;
  SequenceMatcher matcher(options);
  ImageDescriptor current;
  for (int k = 0; k < 4; ++k) {
    current = descriptors.next();
    matcher.push(current);
  }
  const auto every = [](size_t) { return true; };
  const ScoreBackground background = matcher.background(database, extractor, every);
  EXPECT_LE(background.index.size(),
            SequenceMatcher::kBackgroundBlock * SequenceMatcher::kBackgroundBlocks);
  EXPECT_GE(background.index.size(), 500u);
  // Every position but the map's first few (no full path ends there).
  EXPECT_NEAR(static_cast<double>(background.places), 3000.0, 30.0);
  // The same positions scored as candidates: the best path ending at each is the same.
  std::vector<SequenceCandidate> candidates;
  std::vector<double> expected;
  for (size_t j = 0; j < background.index.size(); j += 97) {
    SequenceCandidate candidate;
    candidate.index = background.index[j];
    candidate.image_score = database.similarity(current.global, candidate.index);
    candidates.push_back(candidate);
    expected.push_back(background.score[j]);
  }
  matcher.score(database, extractor, every, &candidates);
  ASSERT_GE(candidates.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(candidates[i].score, expected[i], 1e-6) << "position " << candidates[i].index;
    // And one at a time, as the calibrated decision's departure check reads them.
    EXPECT_NEAR(matcher.pathScore(candidates[i].index, database, extractor), expected[i], 1e-6);
  }
  EXPECT_EQ(matcher.pathScore(database.size(), database, extractor), -1.0);
  // A place the exclusion leaves out is not in the background.
  const ScoreBackground without_recent =
      matcher.background(database, extractor, [](size_t index) { return index < 2900; });
  for (const size_t index : without_recent.index) EXPECT_LT(index, 2900u);
  EXPECT_LT(without_recent.places, background.places);
}
