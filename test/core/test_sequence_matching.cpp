#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "random_descriptors.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::place;
using test_support::PlaceExtractor;

using test_support::feed;

namespace {

// Sequences of 4 keyframes; the k-chain is off (k = 1), so only the sequence decides.
LoopDetectorOptions sequenceOptions() {
  LoopDetectorOptions options = test_support::smallOptions();
  options.acceptance.min_score = 0.8;
  options.acceptance.consistent_keyframes = 1;
  options.acceptance.sequence.length = 4;
  return options;
}

}  // namespace

TEST(SequenceMatching, ARevisitIsAcceptedOnceTheSequenceIsLongEnough) {
  LoopDetector detector(sequenceOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) EXPECT_FALSE(feed(&detector, i, i).keyframe->loop);
  // Revisit 10, 11, 12, 13: the path's mean is 1/4, 2/4, 3/4 (history of 40.. holds novel
  // places before), then 1.
  EXPECT_FALSE(feed(&detector, 40, 10).keyframe->loop);
  EXPECT_FALSE(feed(&detector, 41, 11).keyframe->loop);
  const FrameResult third = feed(&detector, 42, 12);
  EXPECT_FALSE(third.keyframe->loop);
  ASSERT_FALSE(third.keyframe->candidates.empty());
  EXPECT_EQ(third.keyframe->candidates[0].match_id, 12u);
  EXPECT_NEAR(third.keyframe->candidates[0].score, 0.75, 1e-9);
  EXPECT_DOUBLE_EQ(third.keyframe->candidates[0].image_score, 1.0);
  const FrameResult fourth = feed(&detector, 43, 13);
  ASSERT_TRUE(fourth.keyframe->loop);
  EXPECT_EQ(fourth.keyframe->loop->match_id, 13u);
  EXPECT_DOUBLE_EQ(fourth.keyframe->loop->score, 1.0);
}

TEST(SequenceMatching, AFasterRevisitIsFoundAtItsSpeed) {
  LoopDetector detector(sequenceOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  // Every second place: speed 2.
  std::optional<AcceptedLoop> loop;
  for (int k = 0; k < 4; ++k) {
    const FrameResult result = feed(&detector, 40 + k, 10 + 2 * k);
    if (result.keyframe->loop) loop = result.keyframe->loop;
  }
  ASSERT_TRUE(loop);
  EXPECT_EQ(loop->match_id, 16u);
  EXPECT_DOUBLE_EQ(loop->score, 1.0);
}

TEST(SequenceMatching, LoneMatchesNeverMakeALoop) {
  LoopDetector detector(sequenceOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  // Each keyframe matches one far-apart place perfectly: a path meets at most two of them
  // (5 then 8 lie on a speed-1 path), so no mean comes near 0.8.
  int i = 40;
  for (int value : {5, 20, 33, 8, 27, 15, 30, 12}) {
    const FrameResult result = feed(&detector, i++, value);
    EXPECT_FALSE(result.keyframe->loop);
    for (const CandidateReport& report : result.keyframe->candidates) {
      EXPECT_LE(report.score, 0.5 + 1e-9);
    }
  }
}

TEST(SequenceMatching, ThePlaceIsCarriedForwardWhenTheImageAloneMissesIt) {
  LoopDetector detector(sequenceOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  for (int k = 0; k < 4; ++k) feed(&detector, 40 + k, 10 + k);
  // The next image looks like nothing stored (place 200), but the sequence leads to place 14:
  // 3 of 4 keyframes agree, mean 0.75 < 0.8, so it is reported, not accepted.
  const FrameResult result = feed(&detector, 44, 200);
  bool carried = false;
  for (const CandidateReport& report : result.keyframe->candidates) {
    if (report.match_id == 14u) {
      carried = true;
      EXPECT_NEAR(report.score, 0.75, 1e-9);
      EXPECT_DOUBLE_EQ(report.image_score, 0.0);
      EXPECT_EQ(report.verdict, CandidateVerdict::kBelowThreshold);
    }
  }
  EXPECT_TRUE(carried);
  EXPECT_FALSE(result.keyframe->loop);
}

TEST(SequenceMatching, TheLoopKeepsTheImageScoresBesideTheSequenceScore) {
  LoopDetectorOptions options = sequenceOptions();
  options.acceptance.min_score = 0.7;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  for (int k = 0; k < 4; ++k) feed(&detector, 40 + k, 10 + k);
  // Place 200 looks like nothing stored; the sequence (mean 0.75) leads to place 14.
  const FrameResult result = feed(&detector, 44, 200);
  ASSERT_TRUE(result.keyframe->loop);
  const AcceptedLoop& loop = *result.keyframe->loop;
  EXPECT_EQ(loop.match_id, 14u);
  EXPECT_NEAR(loop.score, 0.75, 1e-9);
  // The image alone: its cosine with place 14, and no re-ranking, so the same.
  EXPECT_NEAR(loop.global_score, 0.0, 0.02);
  EXPECT_DOUBLE_EQ(loop.rerank_score, loop.global_score);
}

TEST(SequenceMatching, ResetForgetsTheHistory) {
  LoopDetector detector(sequenceOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  for (int k = 0; k < 3; ++k) feed(&detector, 40 + k, 10 + k);
  detector.map().reset();
  for (int i = 0; i < 40; ++i) feed(&detector, 100 + i, i);
  // The history restarted with the new map: 3 old revisit keyframes no longer count.
  const FrameResult result = feed(&detector, 140, 13);
  EXPECT_FALSE(result.keyframe->loop);
}

TEST(SequenceMatching, OptionsAreValidated) {
  SequenceMatchingOptions options;
  EXPECT_EQ(options.validate(), "");
  EXPECT_TRUE(options.enabled()) << "sequences of 5 keyframes by default";
  EXPECT_EQ(options.length, 5);
  EXPECT_EQ(options.speeds().size(), 7u);  // 0.5, 0.75, ..., 2.0.
  options.length = 0;
  EXPECT_NE(options.validate().find("sequence_length"), std::string::npos);
  options = {};
  options.min_speed = 2.0;
  options.max_speed = 1.0;
  EXPECT_NE(options.validate().find("sequence_min_speed"), std::string::npos);
  options = {};
  options.speed_step = 0.0;
  EXPECT_NE(options.validate().find("sequence_speed_step"), std::string::npos);
  LoopDetectorOptions detector = sequenceOptions();
  detector.acceptance.sequence.length = -3;
  EXPECT_THROW(LoopDetector(detector, std::make_shared<PlaceExtractor>()), std::invalid_argument);
}

// The calibrated decision's background is computed for every keyframe, from the first: a slot's
// cached blocks, laid out while the history was shorter, are read again once it is full. They
// must give what a history filled before the first background gives (they were once read at
// other offsets and past their end: a heap overflow that crashed one benchmark run in a dozen).
TEST(SequenceMatching, ABackgroundWhileTheHistoryFillsScoresAsOneOfAFullHistory) {
  const int dimension = 32;
  KeyframeDatabase database(dimension);
  test_support::RandomDescriptors descriptors(dimension, 5);
  descriptors.fill(&database, 3000);
  PlaceExtractor extractor;
  SequenceMatchingOptions options;
  options.length = 5;
  std::vector<ImageDescriptor> keyframes;
  for (int k = 0; k < options.length; ++k) keyframes.push_back(descriptors.next());
  const auto every = [](size_t) { return true; };
  SequenceMatcher growing(options);
  ScoreBackground grown;
  for (const ImageDescriptor& keyframe : keyframes) {
    growing.push(keyframe);
    grown = growing.background(database, extractor, every);
  }
  SequenceMatcher full(options);
  for (const ImageDescriptor& keyframe : keyframes) full.push(keyframe);
  const ScoreBackground expected = full.background(database, extractor, every);
  ASSERT_EQ(grown.index, expected.index);
  ASSERT_EQ(grown.score.size(), expected.score.size());
  for (size_t i = 0; i < expected.score.size(); ++i) {
    ASSERT_NEAR(grown.score[i], expected.score[i], 1e-6) << "position " << expected.index[i];
  }
}
