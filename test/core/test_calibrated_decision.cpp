// The calibrated decision on its own: a map of unrelated places (random unit vectors), a query of
// another run, candidates scored as the detector scores them.
#include <gtest/gtest.h>

#include "landmark_loop_closure/core/calibrated_decision.h"
#include "place_extractor.h"
#include "random_descriptors.h"

using namespace landmark_loop_closure;

namespace {

constexpr int kDimension = 256;

LoopDetectorOptions singleImageOptions() {
  LoopDetectorOptions options;
  options.acceptance.sequence.length = 1;  // Scores are the keyframes' own cosines.
  return options;
}

// A map of `places` keyframes of session 0, and a query of session 1 that revisits `revisited`.
struct Scene {
  explicit Scene(uint64_t places, uint64_t revisited = 250,
                 const LoopDetectorOptions& options = singleImageOptions())
      : database(kDimension), sequences(options.acceptance.sequence) {
    test_support::RandomDescriptors descriptors(kDimension, 3);
    descriptors.fill(&database, places);
    query.id = 1000;
    query.stamp = 1000.0;
    query.session = 1;
    query.descriptor =
        revisited < places ? database.record(revisited)->descriptor : descriptors.next();
    sequences.push(query.descriptor);
  }
  DecisionContext context() {
    return DecisionContext{database, extractor, sequences, DetectorMode::kMapping, 1};
  }
  CandidateReport candidate(uint64_t match_id) const {
    CandidateReport report;
    report.match_id = match_id;
    report.score = database.similarity(query.descriptor.global, *database.indexOf(match_id));
    return report;
  }

  /// The decision's verdict on `match_id` as `query`'s candidate (its false_alarms and places).
  CandidateReport judge(CalibratedDecision* decision, uint64_t match_id,
                        const KeyframeRecord& as_query) {
    CandidateReport report = candidate(match_id);
    decision->passes(&report, as_query, context());
    return report;
  }

  KeyframeDatabase database;
  test_support::PlaceExtractor extractor;
  SequenceMatcher sequences;
  KeyframeRecord query;
};

// The scene's query is judged and publishes its loop to the revisited place, 250.
bool publishRevisit(CalibratedDecision* decision, Scene* scene) {
  decision->record(scene->query, scene->context());
  CandidateReport first = scene->candidate(250);
  if (!decision->passes(&first, scene->query, scene->context())) return false;
  decision->published(scene->query, *scene->database.findSummary(250), 1);
  return true;
}

}  // namespace

TEST(CalibratedDecision, TheRevisitedPlaceStandsOutAndAnOrdinaryOtherPlaceDoesNot) {
  CalibratedDecision decision(singleImageOptions());
  Scene scene(500);
  ASSERT_TRUE(decision.appliesTo(scene.extractor));
  decision.record(scene.query, scene.context());
  CandidateReport revisit = scene.candidate(250);
  EXPECT_GT(revisit.score, 0.95);
  EXPECT_TRUE(decision.passes(&revisit, scene.query, scene.context())) << revisit.detail;
  EXPECT_GE(revisit.false_alarms, 0.0);
  EXPECT_LT(revisit.false_alarms, 1e-3);
  EXPECT_GT(revisit.false_alarm_places, 400u);  // Every other place could be mistaken for it.
  EXPECT_FALSE(revisit.continues_loop);
  // The best-scoring of the others is still what a wrong place scores.
  CandidateReport best_other;
  best_other.score = -1.0;
  for (uint64_t id = 0; id < 500; ++id) {
    if (id == 250) continue;
    const CandidateReport other = scene.candidate(id);
    if (other.score > best_other.score) best_other = other;
  }
  EXPECT_FALSE(decision.passes(&best_other, scene.query, scene.context()));
  EXPECT_NE(best_other.detail.find("wrong places expected to score as high"), std::string::npos)
      << best_other.detail;
  EXPECT_GT(best_other.false_alarms, singleImageOptions().acceptance.max_false_alarms);
}

TEST(CalibratedDecision, TooSmallAMapToTellWhatAWrongPlaceScoresRefusesEveryCandidate) {
  CalibratedDecision decision(singleImageOptions());
  Scene scene(6, 3);
  decision.record(scene.query, scene.context());
  CandidateReport revisit = scene.candidate(3);
  EXPECT_FALSE(decision.passes(&revisit, scene.query, scene.context()));
  EXPECT_NE(revisit.detail.find("too few other places"), std::string::npos) << revisit.detail;
}

TEST(CalibratedDecision, OffWithoutABoundItPassesEveryCandidateUntested) {
  LoopDetectorOptions options = singleImageOptions();
  options.acceptance.max_false_alarms = 0.0;
  CalibratedDecision decision(options);
  Scene scene(500);
  EXPECT_FALSE(decision.appliesTo(scene.extractor));
  decision.record(scene.query, scene.context());
  CandidateReport other = scene.candidate(7);
  EXPECT_TRUE(decision.passes(&other, scene.query, scene.context()));
  EXPECT_EQ(other.false_alarms, -1.0);
  EXPECT_EQ(other.false_alarm_places, 0u);
}

// The keyframe after a published loop: a candidate that keeps up with it is one of the few places
// that would continue it (2 index_window + 1), one that falls behind is one of the map's; after a
// reset nothing continues.
TEST(CalibratedDecision, ACandidateContinuingTheLastLoopIsTestedAmongTheFewThatWould) {
  const LoopDetectorOptions options = singleImageOptions();
  const size_t continuing_places = 2 * static_cast<size_t>(options.acceptance.index_window) + 1;
  CalibratedDecision decision(options);
  Scene scene(500);
  ASSERT_TRUE(publishRevisit(&decision, &scene));

  KeyframeRecord next = scene.query;
  next.id = scene.query.id + 1;
  next.stamp = scene.query.stamp + 1.0;
  decision.record(next, scene.context());
  const CandidateReport ahead = scene.judge(&decision, 251, next);
  EXPECT_TRUE(ahead.continues_loop);
  EXPECT_EQ(ahead.false_alarm_places, continuing_places);
  const CandidateReport behind = scene.judge(&decision, 249, next);
  EXPECT_FALSE(behind.continues_loop);  // Within reach, but falling behind its place.
  EXPECT_EQ(behind.false_alarm_places, continuing_places);
  const CandidateReport elsewhere = scene.judge(&decision, 100, next);
  EXPECT_FALSE(elsewhere.continues_loop);
  EXPECT_GT(elsewhere.false_alarm_places, 400u);

  decision.reset();
  decision.record(next, scene.context());
  const CandidateReport after_reset = scene.judge(&decision, 251, next);
  EXPECT_FALSE(after_reset.continues_loop);
  EXPECT_GT(after_reset.false_alarm_places, 400u);
}

// Keyframes after a published loop that were refused by a later check (night, a passing car): a
// candidate where the same pace puts the stretch is still one of the few places that would
// continue it, up to continue_across keyframes; one standing on the old match, or past that
// many keyframes, is one of the map's.
TEST(CalibratedDecision, ALoopIsContinuedAcrossKeyframesRefusedInBetween) {
  LoopDetectorOptions options = singleImageOptions();
  options.acceptance.continue_across = 4;
  const size_t continuing_places = 2 * static_cast<size_t>(options.acceptance.index_window) + 1;
  CalibratedDecision decision(options);
  Scene scene(500);
  ASSERT_TRUE(publishRevisit(&decision, &scene));

  const auto later = [&](uint64_t keyframes) {
    KeyframeRecord query = scene.query;
    query.id = scene.query.id + keyframes;
    query.stamp = scene.query.stamp + static_cast<double>(keyframes);
    decision.record(query, scene.context());
    return query;
  };
  const KeyframeRecord second = later(2);  // One keyframe between, no loop published.
  const CandidateReport on_pace = scene.judge(&decision, 252, second);
  EXPECT_TRUE(on_pace.continues_loop);
  EXPECT_EQ(on_pace.false_alarm_places, continuing_places);
  const CandidateReport standing = scene.judge(&decision, 250, second);
  EXPECT_FALSE(standing.continues_loop);  // The stretch fell behind the query.
  EXPECT_EQ(standing.false_alarm_places, continuing_places);
  const CandidateReport behind = scene.judge(&decision, 249, second);
  EXPECT_GT(behind.false_alarm_places, 400u);

  const KeyframeRecord fourth = later(4);  // Three keyframes between.
  const CandidateReport ahead = scene.judge(&decision, 255, fourth);
  EXPECT_TRUE(ahead.continues_loop);
  EXPECT_EQ(ahead.false_alarm_places, continuing_places);

  const KeyframeRecord fifth = later(5);  // Past continue_across.
  const CandidateReport too_late = scene.judge(&decision, 255, fifth);
  EXPECT_FALSE(too_late.continues_loop);
  EXPECT_GT(too_late.false_alarm_places, 400u);
}
