#include <gtest/gtest.h>

#include <cmath>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/core/score_normalisation.h"
#include "small_detector.h"

namespace landmark_loop_closure {
namespace {

TEST(PreviousKeyframeScore, DividesByWhatTheSamePlaceScoresNow) {
  // At night the query resembles its own predecessor at 0.5 only: 0.4 is then a strong match.
  EXPECT_DOUBLE_EQ(previousKeyframeScore(0.4, 0.5), 0.8);
  // By day the predecessor scores 0.9: the same 0.4 is weak.
  EXPECT_NEAR(previousKeyframeScore(0.4, 0.9), 0.4 / 0.9, 1e-12);
}

TEST(PreviousKeyframeScore, CappedAtOneAndZeroWithoutEvidence) {
  EXPECT_DOUBLE_EQ(previousKeyframeScore(0.7, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(previousKeyframeScore(0.4, 0.0), 0.0);  // No predecessor (first keyframe).
  EXPECT_DOUBLE_EQ(previousKeyframeScore(0.4, -0.2), 0.0);
  EXPECT_DOUBLE_EQ(previousKeyframeScore(-0.1, 0.5), 0.0);
}

TEST(StandardisedScore, CountsSpreadsAboveTheMean) {
  const std::vector<double> population = {0.1, 0.2, 0.3, 0.2};
  // Mean 0.2, sample standard deviation sqrt(0.02 / 3).
  EXPECT_NEAR(standardisedScore(0.5, population), 0.3 / std::sqrt(0.02 / 3.0), 1e-9);
  EXPECT_NEAR(standardisedScore(0.2, population), 0.0, 1e-12);
  EXPECT_LT(standardisedScore(0.1, population), 0.0);
}

TEST(StandardisedScore, AlikeMapsMakeTheSameSimilarityWeaker) {
  // A dark run where everything scores about 0.5: 0.6 stands out less than among spread scores.
  const std::vector<double> alike = {0.45, 0.5, 0.55, 0.5, 0.48, 0.52};
  const std::vector<double> spread = {0.0, 0.1, 0.2, 0.15, 0.05, 0.1};
  EXPECT_LT(standardisedScore(0.6, alike), standardisedScore(0.6, spread));
}

TEST(StandardisedScore, NoSpreadOrTooFewValuesGiveZero) {
  EXPECT_DOUBLE_EQ(standardisedScore(0.9, {}), 0.0);
  EXPECT_DOUBLE_EQ(standardisedScore(0.9, {0.3}), 0.0);
  EXPECT_DOUBLE_EQ(standardisedScore(0.9, {0.3, 0.3, 0.3}), 0.0);
}

TEST(ScoreNormalisationOptions, EveryNormalisationIsValidWithSingleImageScores) {
  ASSERT_EQ(scoreNormalisationNames().size(), 4u);
  for (const auto& [name, value] : scoreNormalisationNames()) {
    AcceptanceOptions options;
    options.sequence.length = 1;
    options.score_normalisation = value;
    EXPECT_TRUE(options.validate().empty()) << name << ": " << options.validate();
  }
}

TEST(ScoreNormalisationOptions, OnlyZScoreWorksWithSequenceMatching) {
  AcceptanceOptions options;
  options.sequence.length = 5;
  options.score_normalisation = ScoreNormalisation::kZScore;
  EXPECT_TRUE(options.validate().empty()) << options.validate();
  for (const ScoreNormalisation single :
       {ScoreNormalisation::kPreviousKeyframe, ScoreNormalisation::kLocalContrast}) {
    options.score_normalisation = single;
    EXPECT_NE(options.validate().find("need advanced/acceptance/sequence_length 1"),
              std::string::npos)
        << options.validate();
  }
}

TEST(Standardisation, IdentityByDefaultAndZeroWithoutSpread) {
  EXPECT_DOUBLE_EQ(Standardisation{}.apply(0.37), 0.37);
  const Standardisation flat = Standardisation::of({0.4, 0.4, 0.4});
  EXPECT_DOUBLE_EQ(flat.apply(0.9), 0.0);
  const Standardisation spread = Standardisation::of({0.1, 0.2, 0.3});
  EXPECT_NEAR(spread.mean, 0.2, 1e-12);
  EXPECT_NEAR(spread.spread, 0.1, 1e-12);
  EXPECT_NEAR(spread.apply(0.5), 3.0, 1e-9);
}

TEST(ScoreNormalisationOptions, MinScoreAboveOneOnlyForStandardisedScores) {
  AcceptanceOptions options;
  options.sequence.length = 1;
  options.min_score = 3.0;
  EXPECT_NE(options.validate().find("advanced/acceptance/min_score 3 is above 1"),
            std::string::npos)
      << options.validate();
  options.score_normalisation = ScoreNormalisation::kPreviousKeyframe;
  EXPECT_FALSE(options.validate().empty());
  options.score_normalisation = ScoreNormalisation::kZScore;
  EXPECT_TRUE(options.validate().empty()) << options.validate();
  options.score_normalisation = ScoreNormalisation::kLocalContrast;
  EXPECT_TRUE(options.validate().empty()) << options.validate();
}

LoopDetectorOptions zScoreOptions() {
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.score_normalisation = ScoreNormalisation::kZScore;
  options.acceptance.min_score = 3.0;
  options.acceptance.min_place_ratio = 0.0;  // Only the normalisation decides here.
  return options;
}

TEST(ScoreNormalisationInTheDetector, ZScoreAcceptsAPlaceThatStandsOutOfTheMap) {
  LoopDetector detector(zScoreOptions(), std::make_shared<test_support::PlaceExtractor>());
  for (int i = 0; i < 40; ++i) ASSERT_FALSE(test_support::feed(&detector, i, i).keyframe->loop);
  test_support::feed(&detector, 40, 10);
  test_support::feed(&detector, 41, 11);
  const FrameResult revisit = test_support::feed(&detector, 42, 12);
  ASSERT_TRUE(revisit.keyframe->loop);
  EXPECT_EQ(revisit.keyframe->loop->match_id, 12u);
  // One keyframe of 37 searched scores 1, the rest 0: about sqrt(37) spreads above the mean.
  EXPECT_GT(revisit.keyframe->loop->score, 5.0);
  EXPECT_NEAR(revisit.keyframe->loop->global_score, 1.0, 0.02);  // The raw cosine stays.
  // The descriptor does not re-rank: the re-ranking stage's score is the global one.
  EXPECT_DOUBLE_EQ(revisit.keyframe->loop->rerank_score, revisit.keyframe->loop->global_score);
}

TEST(ScoreNormalisationInTheDetector, ZScoreRefusesAPlaceHalfTheMapLooksLike) {
  LoopDetector detector(zScoreOptions(), std::make_shared<test_support::PlaceExtractor>());
  // Two places in turn, like a corridor of identical doors.
  for (int i = 0; i < 40; ++i) test_support::feed(&detector, i, i % 2);
  for (int i = 40; i < 46; ++i) {
    const FrameResult result = test_support::feed(&detector, i, i % 2);
    EXPECT_FALSE(result.keyframe->loop) << "keyframe " << i;
    ASSERT_FALSE(result.keyframe->candidates.empty());
    const CandidateReport& best = result.keyframe->candidates.front();
    EXPECT_NEAR(best.global_score, 1.0, 0.02);
    EXPECT_LT(best.score, 1.5);  // Half the map scores 1: about one spread above the mean.
    EXPECT_EQ(best.verdict, CandidateVerdict::kBelowThreshold);
  }
}

TEST(ScoreNormalisationInTheDetector, PreviousKeyframeScoresNothingForAQueryUnlikeItsPredecessor) {
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.score_normalisation = ScoreNormalisation::kPreviousKeyframe;
  LoopDetector detector(options, std::make_shared<test_support::PlaceExtractor>());
  for (int i = 0; i < 40; ++i) test_support::feed(&detector, i, i);
  // Each keyframe shows another place than the one before: nothing says what "alike" is now.
  const FrameResult revisit = test_support::feed(&detector, 40, 10);
  ASSERT_FALSE(revisit.keyframe->candidates.empty());
  EXPECT_DOUBLE_EQ(revisit.keyframe->candidates.front().score, 0.0);
  EXPECT_NEAR(revisit.keyframe->candidates.front().global_score, 1.0, 0.02);
}

LoopDetectorOptions zScoreSequenceOptions() {
  LoopDetectorOptions options = zScoreOptions();
  options.acceptance.sequence.length = 4;
  options.acceptance.consistent_keyframes = 1;  // Only the standardised sequence decides.
  return options;
}

TEST(ScoreNormalisationInTheDetector, ZScoreSequenceAcceptsARevisitAlongItsPath) {
  LoopDetector detector(zScoreSequenceOptions(), std::make_shared<test_support::PlaceExtractor>());
  for (int i = 0; i < 40; ++i) ASSERT_FALSE(test_support::feed(&detector, i, i).keyframe->loop);
  // The first revisit keyframe's path holds one match among novel places: a quarter of it.
  EXPECT_FALSE(test_support::feed(&detector, 40, 10).keyframe->loop);
  test_support::feed(&detector, 41, 11);
  test_support::feed(&detector, 42, 12);
  const FrameResult whole_path = test_support::feed(&detector, 43, 13);
  ASSERT_TRUE(whole_path.keyframe->loop);
  const AcceptedLoop& loop = *whole_path.keyframe->loop;
  EXPECT_EQ(loop.match_id, 13u);
  // Each of the four steps stands about sqrt(N) spreads out; so does the path's mean.
  EXPECT_GT(loop.score, 5.0);
  EXPECT_NEAR(loop.global_score, 1.0, 0.02);  // The raw cosine stays.
}

TEST(ScoreNormalisationInTheDetector, ZScoreSequenceRefusesAPathHalfTheMapLooksLike) {
  LoopDetector detector(zScoreSequenceOptions(), std::make_shared<test_support::PlaceExtractor>());
  for (int i = 0; i < 40; ++i) test_support::feed(&detector, i, i % 2);
  for (int i = 40; i < 48; ++i) {
    const FrameResult result = test_support::feed(&detector, i, i % 2);
    EXPECT_FALSE(result.keyframe->loop) << "keyframe " << i;
    for (const CandidateReport& report : result.keyframe->candidates) {
      EXPECT_LT(report.score, 1.5) << "keyframe " << i;
    }
  }
}

}  // namespace
}  // namespace landmark_loop_closure
