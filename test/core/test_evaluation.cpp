#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "landmark_loop_closure/eval/detector_evaluation.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/eval/training.h"
#include "place_extractor.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::eval;
namespace fs = std::filesystem;
using test_support::PlaceExtractor;

namespace {

cv::Mat place(int value) { return test_support::place(value, cv::Size(8, 8)); }

QueryOutcome outcome(size_t query, double score, bool correct, bool has_truth = true) {
  QueryOutcome o;
  o.query = query;
  o.match = 0;
  o.score = score;
  o.correct = correct;
  o.has_truth = has_truth;
  return o;
}

}  // namespace

TEST(Metrics, HandComputedCurve) {
  // Scores high to low: T, T, F, T; five queries have a place (one never found).
  const std::vector<QueryOutcome> outcomes = {outcome(0, 0.9, true), outcome(1, 0.8, true),
                                              outcome(2, 0.7, false), outcome(3, 0.6, true),
                                              outcome(4, 0.1, false)};
  const Metrics m = computeMetrics(outcomes);
  ASSERT_EQ(m.curve.size(), 5u);
  EXPECT_EQ(m.queries_with_truth, 5u);
  EXPECT_DOUBLE_EQ(m.recall_at_100_precision, 2.0 / 5.0);
  EXPECT_DOUBLE_EQ(m.threshold_at_100_precision, 0.8);
  EXPECT_DOUBLE_EQ(m.recall_at_1, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(m.curve[2].precision, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.curve[3].precision, 3.0 / 4.0);
  // AP: (1 + 1 + 3/4) / 5.
  EXPECT_DOUBLE_EQ(m.average_precision, (1.0 + 1.0 + 0.75) / 5.0);
  // AUC: trapezoids (0,1)->(.2,1)->(.4,1)->(.4,2/3)->(.6,3/4)->(.6,3/5).
  EXPECT_NEAR(m.auc, 0.2 + 0.2 + 0.0 + 0.2 * (2.0 / 3.0 + 0.75) / 2.0 + 0.0, 1e-12);
}

TEST(Metrics, VprBenchConventionDividesByTheCorrectlyMatchedQueries) {
  // Same outcomes as above: three best matches are right, so recall is counted out of 3, not 5.
  const Metrics m =
      computeMetrics({outcome(0, 0.9, true), outcome(1, 0.8, true), outcome(2, 0.7, false),
                      outcome(3, 0.6, true), outcome(4, 0.1, false)});
  EXPECT_EQ(m.vprbench.correct_matches, 3u);
  ASSERT_EQ(m.vprbench.curve.size(), 5u);
  EXPECT_DOUBLE_EQ(m.vprbench.recall_at_100_precision, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.vprbench.curve.back().recall, 1.0);
  EXPECT_DOUBLE_EQ(m.vprbench.curve.back().precision, 3.0 / 5.0);
  // Trapezoids from sklearn's final point (0,1): (0,1)->(1/3,1)->(2/3,1)->(2/3,2/3)->(1,3/4)
  // ->(1,3/5).
  EXPECT_NEAR(m.vprbench.auc, 1.0 / 3.0 + 1.0 / 3.0 + (2.0 / 3.0 + 0.75) / 2.0 / 3.0, 1e-12);
}

TEST(Metrics, VprBenchFiguresMatchScikitLearnsOnTiedScores) {
  // scripts/vprbench_reference.py computes these with scikit-learn's precision_recall_curve and
  // auc, as VPR-Bench does, for the same generated outcomes (60 queries, 23 score levels).
  std::vector<QueryOutcome> outcomes;
  for (size_t i = 0; i < 60; ++i) {
    outcomes.push_back(outcome(i, static_cast<double>((i * 37) % 23) / 22.0, (i * 11) % 7 < 4));
  }
  const Metrics m = computeMetrics(outcomes);
  EXPECT_EQ(m.vprbench.correct_matches, 34u);
  EXPECT_NEAR(m.vprbench.auc, 0.55471818353560931, 1e-12);
  EXPECT_NEAR(m.vprbench.recall_at_100_precision, 0.058823529411764705, 1e-12);
}

TEST(Evaluation, ConditionStandardisationRunsInListOrderAndSkipsUndecodedImages) {
  DescribedImages images;
  images.descriptors.resize(3);
  images.descriptors[0].global = {1.0f, 0.0f};
  images.descriptors[1].global = {5.0f, 5.0f};  // Did not decode: neither changed nor averaged.
  images.descriptors[2].global = {0.0f, 1.0f};
  images.valid = {true, false, true};
  standardiseConditions(&images, 0);
  EXPECT_EQ(images.descriptors[0].global, (std::vector<float>{1.0f, 0.0f})) << "0: as described";
  standardiseConditions(&images, 2);
  EXPECT_EQ(images.descriptors[0].global, (std::vector<float>{0.0f, 0.0f}))
      << "alone in its window";
  EXPECT_EQ(images.descriptors[1].global, (std::vector<float>{5.0f, 5.0f}));
  // (0, 1) less the mean of (1, 0) and (0, 1), normalised.
  EXPECT_NEAR(images.descriptors[2].global[0], -std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(images.descriptors[2].global[1], std::sqrt(0.5), 1e-6);
}

TEST(Evaluation, AStoredTraversalsFirstImagesWaitForTheFirstFullWindow) {
  DescribedImages images;
  images.descriptors.resize(4);
  images.descriptors[0].global = {1.0f, 0.0f};
  images.descriptors[1].global = {5.0f, 5.0f};  // Did not decode: waits for nothing.
  images.descriptors[2].global = {0.0f, 1.0f};
  images.descriptors[3].global = {0.0f, 3.0f};
  images.valid = {true, false, true, true};
  DescribedImages searched = images;
  standardiseConditions(&searched, 3, ConditionStart::kSearched);
  standardiseConditions(&images, 3, ConditionStart::kStored);
  EXPECT_EQ(searched.descriptors[0].global, (std::vector<float>{0.0f, 0.0f}))
      << "searched: alone in its window";
  // Stored: (1, 0) less the mean of the first full window, (1, 0), (0, 1), (0, 3): (2/3, -4/3).
  const float norm = std::sqrt(4.0f / 9.0f + 16.0f / 9.0f);
  EXPECT_NEAR(images.descriptors[0].global[0], (2.0f / 3.0f) / norm, 1e-6);
  EXPECT_NEAR(images.descriptors[0].global[1], (-4.0f / 3.0f) / norm, 1e-6);
  EXPECT_EQ(images.descriptors[1].global, (std::vector<float>{5.0f, 5.0f}));
  // (0, 1) likewise: (-1/3, -1/3), normalised; searched it was (0, 1) less the mean of two.
  EXPECT_NEAR(images.descriptors[2].global[0], -std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(images.descriptors[2].global[1], -std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(searched.descriptors[2].global[0], -std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(searched.descriptors[2].global[1], std::sqrt(0.5), 1e-6);
  // The image that fills the window is the same either way.
  EXPECT_EQ(images.descriptors[3].global, searched.descriptors[3].global);
}

TEST(Evaluation, AStoredTraversalShorterThanTheWindowStaysAsSearched) {
  DescribedImages images;
  images.descriptors.resize(2);
  images.descriptors[0].global = {1.0f, 0.0f};
  images.descriptors[1].global = {0.0f, 1.0f};
  images.valid = {true, true};
  DescribedImages searched = images;
  standardiseConditions(&searched, 10, ConditionStart::kSearched);
  standardiseConditions(&images, 10, ConditionStart::kStored);
  EXPECT_EQ(images.descriptors[0].global, searched.descriptors[0].global);
  EXPECT_EQ(images.descriptors[1].global, searched.descriptors[1].global);
}

TEST(Metrics, PerfectAndEmpty) {
  const Metrics perfect = computeMetrics({outcome(0, 0.9, true), outcome(1, 0.5, true)});
  EXPECT_DOUBLE_EQ(perfect.recall_at_100_precision, 1.0);
  EXPECT_DOUBLE_EQ(perfect.auc, 1.0);
  EXPECT_DOUBLE_EQ(perfect.average_precision, 1.0);
  const Metrics none = computeMetrics({});
  EXPECT_EQ(none.queries, 0u);
  EXPECT_DOUBLE_EQ(none.recall_at_100_precision, 0.0);
}

TEST(Metrics, AFalseMatchAtTheTopMeansNoRecallAtFullPrecision) {
  const Metrics m = computeMetrics({outcome(0, 0.99, false), outcome(1, 0.9, true)});
  EXPECT_DOUBLE_EQ(m.recall_at_100_precision, 0.0);
}

TEST(Metrics, TiedScoresPassOrFailTogether) {
  const Metrics m = computeMetrics({outcome(0, 0.5, true), outcome(1, 0.5, false)});
  ASSERT_EQ(m.curve.size(), 1u);
  EXPECT_DOUBLE_EQ(m.recall_at_100_precision, 0.0);
  EXPECT_DOUBLE_EQ(m.curve[0].precision, 0.5);
}

TEST(Metrics, QueriesWithoutAPlaceOnlyAddFalsePositives) {
  const Metrics m = computeMetrics({outcome(0, 0.9, true), outcome(1, 0.95, false, false)});
  EXPECT_EQ(m.queries_with_truth, 1u);
  EXPECT_DOUBLE_EQ(m.recall_at_100_precision, 0.0);
  EXPECT_DOUBLE_EQ(m.recall_at_1, 1.0);
}

TEST(Percentiles, NearestRank) {
  std::vector<double> values;
  for (int i = 1; i <= 100; ++i) values.push_back(i);
  const Percentiles p = percentiles(values);
  EXPECT_DOUBLE_EQ(p.median, 50.0);
  EXPECT_DOUBLE_EQ(p.p99, 99.0);
  EXPECT_DOUBLE_EQ(percentiles({}).median, 0.0);
}

TEST(Evaluator, TraversalsFindTheAlignedPlace) {
  const PlaceExtractor extractor;
  const auto images = [](int offset) {
    return [offset](size_t i) { return place(static_cast<int>(i) + offset); };
  };
  const DescribedImages database = describeImages(10, images(0), extractor);
  // Queries 0..9 show places 0..9 except query 7, which shows place 3.
  const DescribedImages queries = describeImages(
      10, [](size_t i) { return place(i == 7 ? 3 : static_cast<int>(i)); }, extractor);
  const Evaluation e = evaluateTraversals(database, queries, alignedGroundTruth(10, 10, 0),
                                          extractor, MatchingOptions{});
  EXPECT_DOUBLE_EQ(e.metrics.recall_at_1, 0.9);
  EXPECT_EQ(e.outcomes[7].match, 3);
  EXPECT_FALSE(e.outcomes[7].correct);
  EXPECT_EQ(e.similarity.size(), cv::Size(10, 10));
  EXPECT_GT(e.bytes_per_image, 0.0);
}

TEST(Evaluator, AQueryOfZerosMatchesNothingAndCountsAsAMiss) {
  const PlaceExtractor extractor;
  const auto images = [](size_t i) { return place(static_cast<int>(i)); };
  const DescribedImages database = describeImages(4, images, extractor);
  DescribedImages queries = describeImages(4, images, extractor);
  // As the first query of a standardised traversal is: it would tie every image at 0.
  std::fill(queries.descriptors[0].global.begin(), queries.descriptors[0].global.end(), 0.0f);
  const Evaluation e = evaluateTraversals(database, queries, alignedGroundTruth(4, 4, 0), extractor,
                                          MatchingOptions{});
  ASSERT_EQ(e.outcomes.size(), 4u);
  EXPECT_EQ(e.outcomes[0].match, -1);
  EXPECT_FALSE(e.outcomes[0].correct);
  EXPECT_TRUE(e.outcomes[0].has_truth);
  EXPECT_DOUBLE_EQ(e.metrics.recall_at_1, 0.75);
  EXPECT_EQ(e.metrics.unmatched_with_truth, 1u);
}

TEST(Evaluator, SequenceRespectsTheExclusionWindowAndSkipsUndecodableImages) {
  const PlaceExtractor extractor;
  // Places 0..9 then 0..9 again; image 12 does not decode.
  const DescribedImages images = describeImages(
      20, [](size_t i) { return i == 12 ? cv::Mat() : place(static_cast<int>(i % 10)); },
      extractor);
  EXPECT_EQ(images.undecodable.size(), 1u);
  GroundTruth truth(20, 20);
  for (size_t i = 10; i < 20; ++i) truth.add(i, i - 10);
  truth.finalize();
  MatchingOptions options;
  options.exclude_recent = 5;
  const Evaluation e = evaluateSequence(images, truth.undirected(), extractor, options);
  EXPECT_EQ(e.outcomes.size(), 19u);
  EXPECT_EQ(e.undecodable, 1u);
  EXPECT_DOUBLE_EQ(e.metrics.recall_at_100_precision, 1.0);
  EXPECT_EQ(e.metrics.queries_with_truth, 9u);  // Image 12 is not a query.
  for (const QueryOutcome& o : e.outcomes) {
    if (o.match >= 0) {
      EXPECT_LT(o.match, static_cast<long>(o.query) - 5);
    }
  }
}

TEST(Evaluator, MismatchedGroundTruthSizeIsAClearError) {
  const PlaceExtractor extractor;
  const DescribedImages images = describeImages(
      5, [](size_t i) { return place(int(i)); }, extractor);
  try {
    evaluateSequence(images, GroundTruth(6, 6), extractor, MatchingOptions{});
    FAIL();
  } catch (const GroundTruthError& error) {
    EXPECT_NE(std::string(error.what()).find("6 x 6"), std::string::npos) << error.what();
  }
}

TEST(Evaluator, NamesSortWithTheirNumbersAsNumbers) {
  EXPECT_TRUE(naturalLess("2.jpg", "10.jpg"));
  EXPECT_FALSE(naturalLess("10.jpg", "2.jpg"));
  EXPECT_TRUE(naturalLess("img9.png", "img010.png"));
  EXPECT_TRUE(naturalLess("a1b2", "a1b10"));
  EXPECT_TRUE(naturalLess("a", "a1"));
  EXPECT_FALSE(naturalLess("x5", "x5"));
  EXPECT_TRUE(naturalLess("x5", "x05"));  // Same number: the order stays total.
  EXPECT_TRUE(textOrderDiffers({"1.jpg", "2.jpg", "10.jpg"}));
  EXPECT_FALSE(textOrderDiffers({"Image000.jpg", "Image001.jpg", "Image010.jpg"}));

  const fs::path folder = fs::temp_directory_path() / "lcd_natural_sort";
  fs::remove_all(folder);
  fs::create_directories(folder);
  for (const char* name : {"10.png", "1.png", "2.png"}) std::ofstream(folder / name) << "x";
  const std::vector<std::string> paths = listImages(folder.string());
  ASSERT_EQ(paths.size(), 3u);
  EXPECT_EQ(fs::path(paths[0]).filename(), "1.png");
  EXPECT_EQ(fs::path(paths[1]).filename(), "2.png");
  EXPECT_EQ(fs::path(paths[2]).filename(), "10.png");
  fs::remove_all(folder);
}

TEST(Evaluator, ListImagesSortsAndRefusesMissingFolders) {
  const fs::path folder = fs::temp_directory_path() / "lcd_list_images";
  fs::remove_all(folder);
  fs::create_directories(folder);
  for (const char* name : {"b.png", "a.png", "c.txt", "d.JPG"}) std::ofstream(folder / name) << "x";
  const std::vector<std::string> paths = listImages(folder.string());
  ASSERT_EQ(paths.size(), 3u);
  EXPECT_EQ(fs::path(paths[0]).filename(), "a.png");
  EXPECT_EQ(fs::path(paths[2]).filename(), "d.JPG");
  EXPECT_THROW(listImages((folder / "missing").string()), GroundTruthError);
  // Files that are not images in fact do not decode: skipped and counted.
  const PlaceExtractor extractor;
  EXPECT_EQ(describeImageFiles(paths, extractor).undecodable.size(), 3u);
}

TEST(Report, WritesResultsCurvesAndPictures) {
  const PlaceExtractor extractor;
  const DescribedImages images = describeImages(
      6, [](size_t i) { return place(int(i % 3)); }, extractor);
  GroundTruth truth(6, 6);
  for (size_t i = 3; i < 6; ++i) truth.add(i, i - 3);
  truth.finalize();
  MatchingOptions options;
  options.exclude_recent = 1;
  const Evaluation e = evaluateSequence(images, truth.undirected(), extractor, options);
  const fs::path folder = fs::temp_directory_path() / "lcd_report";
  fs::remove_all(folder);
  RunDescription run;
  run.dataset = "test \"quoted\"";
  run.mode = "sequence";
  const std::string results = writeReport(folder.string(), run, {e}, truth, 100);
  std::ifstream json(results);
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"recall_at_100_precision\": 1"), std::string::npos) << text;
  EXPECT_NE(text.find("test \\\"quoted\\\""), std::string::npos);
  EXPECT_TRUE(fs::exists(folder / "pr_place.csv"));
  EXPECT_TRUE(fs::exists(folder / "matches_place.csv"));
  EXPECT_FALSE(cv::imread((folder / "similarity_place.png").string()).empty());
  EXPECT_FALSE(cv::imread((folder / "ground_truth.png").string()).empty());
  EXPECT_GT(peakResidentBytes(), 0u);
  EXPECT_TRUE(fs::exists(folder / "pr_vprbench_place.csv"));
  EXPECT_NE(text.find("\"vprbench\": {\"recall_at_100_precision\": 1"), std::string::npos);

  // The best pairs drawn for a person to look at: 2 pairs -> one row of the 3-column grid.
  const fs::path sheet = folder / "contact_place.png";
  writeContactSheet(
      sheet.string(), e.outcomes, [](size_t i) { return place(int(i % 3)); },
      [](size_t i) { return place(int(i % 3)); }, true, 2);
  const cv::Mat picture = cv::imread(sheet.string());
  ASSERT_FALSE(picture.empty());
  EXPECT_GT(picture.cols, picture.rows);
}

TEST(GroundTruth, AnAllZeroMatrixIsRefusedWithWhatToDo) {
  GroundTruth empty(5, 5);
  empty.finalize();
  try {
    requirePositives(empty, "file.mat");
    FAIL();
  } catch (const GroundTruthError& error) {
    const std::string text = error.what();
    EXPECT_NE(text.find("file.mat"), std::string::npos) << text;
    EXPECT_NE(text.find("--no-ground-truth"), std::string::npos) << text;
  }
  GroundTruth one(5, 5);
  one.add(3, 1);
  one.finalize();
  EXPECT_NO_THROW(requirePositives(one, "file.mat"));
}

namespace {

// Places 0..39, then places 10..29 again (true revisits): frame i shows place(i).
int placeOfFrame(size_t frame) { return frame < 40 ? int(frame) : int(frame) - 30; }

LoopDetectorOptions smallDetector() {
  LoopDetectorOptions options;
  options.keyframe.min_motion = 0.5;
  options.database.exclude_recent_keyframes = 5;
  options.database.exclude_recent_seconds = 0.0;
  options.database.min_size = 10;
  options.acceptance.min_score = 0.5;
  options.odometry_gate.enabled = false;
  options.verification.enabled = false;
  options.acceptance.sequence.length = 1;  // The k-keyframe chain's counts below.
  return options;
}

}  // namespace

TEST(DetectorEvaluation, ScoresThePublishedLoopsAndSweepsTheThreshold) {
  const FramePlayer play = [](const std::function<void(size_t, const DetectorFrame&)>& sink) {
    for (size_t i = 0; i < 60; ++i) {
      DetectorFrame frame;
      frame.stamp = 1.0 + i;
      frame.pose = planarPose(double(i), 0, 0);
      frame.image = test_support::place(placeOfFrame(i));
      sink(i, frame);
    }
  };
  const SamePlace same = [](size_t q, size_t m) { return placeOfFrame(q) == placeOfFrame(m); };
  const DetectorEvaluation result =
      evaluateDetector(smallDetector(), std::make_shared<PlaceExtractor>(), play, same);
  EXPECT_EQ(result.frames, 60u);
  EXPECT_EQ(result.keyframes, 60u);
  EXPECT_EQ(result.revisits, 20u);
  // k = 3: the first two revisits only start the chain.
  EXPECT_EQ(result.configured.loops.size(), 18u);
  EXPECT_EQ(result.configured.true_loops, 18u);
  EXPECT_DOUBLE_EQ(result.configured.precision, 1.0);
  EXPECT_DOUBLE_EQ(result.configured.recall, 0.9);
  EXPECT_EQ(result.configured.refused.at("awaiting_consistency"), 2u);
  EXPECT_EQ(result.configured.refused.at("database_too_small"), 10u);
  EXPECT_EQ(result.configured.loops.front().query_frame, 42u);
  EXPECT_EQ(result.configured.loops.front().match_frame, 12u);
  EXPECT_DOUBLE_EQ(result.recall_at_100_precision, 0.9);
  EXPECT_FALSE(result.sweep.empty());
  for (const DetectorPass& pass : result.sweep) EXPECT_LE(pass.loops.size(), 18u);

  // A ground truth that calls every match wrong: nothing is clean but the empty passes.
  const DetectorEvaluation wrong =
      evaluateDetector(smallDetector(), std::make_shared<PlaceExtractor>(), play,
                       [](size_t q, size_t) { return q >= 40 && q < 42; });
  EXPECT_DOUBLE_EQ(wrong.configured.precision, 0.0);
  EXPECT_DOUBLE_EQ(wrong.recall_at_100_precision, 0.0);

  const fs::path folder = fs::temp_directory_path() / "lcd_detector_report";
  fs::remove_all(folder);
  const std::string path = writeDetectorReport(folder.string(), "place", "test \"quoted\"", result);
  std::ifstream json(path);
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"revisited_keyframes\": 20"), std::string::npos) << text;
  EXPECT_NE(text.find("test \\\"quoted\\\""), std::string::npos) << text;
  std::ifstream loops(folder / "loops_place.csv");
  std::string header;
  std::getline(loops, header);
  EXPECT_EQ(header, "query_id,match_id,query_frame,match_frame,score,verified,correct");
}

TEST(DetectorEvaluation, RunProtocolsPlayTheSecondRunAsARobotWould) {
  // Run 1: places 0..39; run 2 (frame 40 on): places 10..29 again, its own odometry from the
  // origin. The odometry gate is on: in one sequence the revisits lie 30 m behind on a straight
  // path, so it refuses them; as a new session (a robot whose odometry restarted, as into a loaded
  // map) they skip it; localising in run 1's map finds them without storing run 2; a robot that
  // came back (one run, its odometry at places 10..29 again) finds them within the gate's reach.
  LoopDetectorOptions options = smallDetector();
  options.odometry_gate.enabled = true;
  enum class Odometry { kStraightOn, kRestarted, kCameBack };
  const auto player = [](Odometry odometry) -> FramePlayer {
    return [odometry](const std::function<void(size_t, const DetectorFrame&)>& sink) {
      for (size_t i = 0; i < 60; ++i) {
        DetectorFrame frame;
        frame.stamp = 1.0 + i;
        const double x = i >= 40 && odometry == Odometry::kRestarted ? double(i) - 40.0 : double(i);
        frame.pose = planarPose(x, 0, 0);
        if (odometry == Odometry::kCameBack) {
          // Round a loop of 30 steps: frame 40 is back at frame 10's place.
          const double angle = 2.0 * M_PI * double(i) / 30.0;
          const double radius = 30.0 / (2.0 * M_PI);
          frame.pose =
              planarPose(radius * std::sin(angle), radius * (1.0 - std::cos(angle)), angle);
        }
        frame.image = test_support::place(placeOfFrame(i));
        frame.new_run = i == 40;
        sink(i, frame);
      }
    };
  };
  const SamePlace same = [](size_t q, size_t m) { return placeOfFrame(q) == placeOfFrame(m); };
  DetectorEvaluationOptions evaluation;
  evaluation.sweep_steps = 0;
  const auto run = [&](RunProtocol protocol, Odometry odometry) {
    evaluation.protocol = protocol;
    return evaluateDetector(options, std::make_shared<PlaceExtractor>(), player(odometry), same,
                            evaluation);
  };
  const DetectorEvaluation one = run(RunProtocol::kOneSequence, Odometry::kStraightOn);
  EXPECT_EQ(one.configured.loops.size(), 0u);
  EXPECT_GT(one.configured.refused.at("odometry_rejected"), 0u);
  const DetectorEvaluation sessions = run(RunProtocol::kSessions, Odometry::kRestarted);
  EXPECT_EQ(sessions.keyframes, 60u) << "the odometry's restart is not a jump";
  EXPECT_EQ(sessions.configured.loops.size(), 18u);
  EXPECT_EQ(sessions.configured.true_loops, 18u);
  const DetectorEvaluation localisation = run(RunProtocol::kLocalisation, Odometry::kStraightOn);
  EXPECT_EQ(localisation.configured.true_loops, localisation.configured.loops.size());
  EXPECT_GE(localisation.configured.loops.size(), 18u);
  const DetectorEvaluation came_back = run(RunProtocol::kOneRun, Odometry::kCameBack);
  EXPECT_EQ(came_back.keyframes, 60u);
  EXPECT_EQ(came_back.configured.loops.size(), 18u);
  EXPECT_EQ(came_back.configured.true_loops, 18u);
  const auto gate_refused = came_back.configured.refused.find("odometry_rejected");
  EXPECT_TRUE(gate_refused == came_back.configured.refused.end() || gate_refused->second == 0u);

  EXPECT_EQ(runProtocol("sessions"), RunProtocol::kSessions);
  EXPECT_STREQ(toString(runProtocol("localisation")), "localisation");
  EXPECT_EQ(runProtocol("one-run"), RunProtocol::kOneRun);
  EXPECT_THROW(runProtocol("robot"), std::invalid_argument);
}

TEST(Training, AFittedWhiteningWrapsAnyExtractor) {
  // Training images: random textures; the whitened global keeps `components` unit-norm values.
  std::vector<cv::Mat> images;
  cv::RNG random(7);
  for (int i = 0; i < 20; ++i) {
    cv::Mat image(48, 64, CV_8UC1);
    random.fill(image, cv::RNG::UNIFORM, 0, 256);
    images.push_back(image);
  }
  DescriptorOptions options;
  options.type = "pixels";
  const auto whitened = withFittedWhitening(
      makeDescriptorExtractor(options), images.size(), [&](size_t i) { return images[i]; }, 8);
  EXPECT_EQ(whitened->name(), "pixels_pca");
  EXPECT_EQ(whitened->globalDimension(), 8);
  const ImageDescriptor d = whitened->describe(images[3]);
  ASSERT_EQ(d.global.size(), 8u);
  double norm = 0.0;
  for (const float v : d.global) norm += v * v;
  EXPECT_NEAR(norm, 1.0, 1e-4);
  EXPECT_NEAR(whitened->similarity(d, whitened->describe(images[3])), 1.0, 1e-5);
  EXPECT_THROW(withFittedWhitening(
                   makeDescriptorExtractor(options), 1, [&](size_t i) { return images[i]; }, 8),
               std::invalid_argument);
}

// Without whitening the projection keeps the training images' centred geometry: with every
// component kept, two training images' cosine is that of their vectors minus the mean.
TEST(Training, ProjectionWithoutWhiteningKeepsCentredCosines) {
  // Mixtures of two textures, plus a little noise: pairs far from the average cosine.
  cv::RNG random(11);
  cv::Mat first(48, 64, CV_32FC1), second(48, 64, CV_32FC1);
  random.fill(first, cv::RNG::UNIFORM, 0, 128);
  random.fill(second, cv::RNG::UNIFORM, 0, 128);
  std::vector<cv::Mat> images;
  for (int i = 0; i < 12; ++i) {
    cv::Mat noise(48, 64, CV_32FC1);
    random.fill(noise, cv::RNG::UNIFORM, 0, 8);
    const double share = i / 11.0;
    cv::Mat image;
    cv::Mat(share * first + (1.0 - share) * second + noise).convertTo(image, CV_8UC1);
    images.push_back(image);
  }
  DescriptorOptions options;
  options.type = "pixels";
  const auto raw = makeDescriptorExtractor(options);
  const auto load = [&](size_t i) { return images[i]; };
  const auto projected = withFittedWhitening(raw, images.size(), load, 11, false);
  const auto whitened = withFittedWhitening(raw, images.size(), load, 11, true);
  std::vector<Eigen::VectorXd> centred;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(raw->globalDimension());
  for (const cv::Mat& image : images) {
    const std::vector<float> global = raw->describe(image).global;
    centred.push_back(
        Eigen::Map<const Eigen::VectorXf>(global.data(), global.size()).cast<double>());
    mean += centred.back() / static_cast<double>(images.size());
  }
  for (Eigen::VectorXd& vector : centred) vector -= mean;
  const double expected = centred[2].normalized().dot(centred[5].normalized());
  EXPECT_NEAR(projected->similarity(projected->describe(images[2]), projected->describe(images[5])),
              expected, 1e-3);
  // Whitening makes the training images equidistant, so it does not keep that cosine.
  EXPECT_GT(
      std::abs(whitened->similarity(whitened->describe(images[2]), whitened->describe(images[5])) -
               expected),
      0.01);
}
