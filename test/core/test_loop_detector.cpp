#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "../../fuzz/loop_detector_input.h"
#include "kept_fuzz_inputs.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::place;
using test_support::PlaceExtractor;

using test_support::feed;
using test_support::smallOptions;

TEST(LoopDetector, AcceptsOnlyAfterKConsistentKeyframes) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) {
    const FrameResult result = feed(&detector, i, i);
    ASSERT_TRUE(result.keyframe);
    EXPECT_FALSE(result.keyframe->loop);
  }
  // Revisit places 10, 11, 12: the first two only start the chain.
  FrameResult r40 = feed(&detector, 40, 10);
  ASSERT_FALSE(r40.keyframe->candidates.empty());
  EXPECT_EQ(r40.keyframe->candidates[0].match_id, 10u);
  EXPECT_EQ(r40.keyframe->candidates[0].verdict, CandidateVerdict::kAwaitingConsistency);
  EXPECT_FALSE(r40.keyframe->loop);
  EXPECT_FALSE(feed(&detector, 41, 11).keyframe->loop);
  const FrameResult r42 = feed(&detector, 42, 12);
  ASSERT_TRUE(r42.keyframe->loop);
  EXPECT_EQ(r42.keyframe->loop->query_id, 42u);
  EXPECT_EQ(r42.keyframe->loop->match_id, 12u);
  EXPECT_EQ(r42.keyframe->loop->consistent_keyframes, 3);
  EXPECT_DOUBLE_EQ(r42.keyframe->loop->score, 1.0);
  EXPECT_DOUBLE_EQ(r42.keyframe->loop->match_pose.position.x(), 12.0);
  EXPECT_DOUBLE_EQ(r42.keyframe->loop->query_stamp, 42.0);
  // Other candidates are reported as below the threshold.
  for (size_t i = 1; i < r42.keyframe->candidates.size(); ++i) {
    EXPECT_EQ(r42.keyframe->candidates[i].verdict, CandidateVerdict::kBelowThreshold);
  }
}

TEST(LoopDetector, InconsistentMatchesNeverMakeALoop) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  // Each revisit matches a different, far-apart place: no chain reaches 3.
  int i = 40;
  for (int value : {5, 20, 33, 8, 27, 15}) {
    EXPECT_FALSE(feed(&detector, i++, value).keyframe->loop);
  }
}

TEST(LoopDetector, NoSearchBeforeTheMinimumDatabaseSize) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 9; ++i) {
    EXPECT_EQ(feed(&detector, i, 7).keyframe->query_status, QueryStatus::kDatabaseTooSmall);
  }
  EXPECT_EQ(feed(&detector, 9, 7).keyframe->query_status, QueryStatus::kDatabaseTooSmall);
  EXPECT_EQ(feed(&detector, 10, 7).keyframe->query_status, QueryStatus::kSearched);
}

TEST(LoopDetector, RedundantFramesAreNotStored) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  EXPECT_TRUE(detector.process(0.0, planarPose(0, 0, 0), place(1)).admission.isKeyframe());
  const FrameResult redundant = detector.process(0.1, planarPose(0.1, 0, 0), place(1));
  EXPECT_EQ(redundant.admission.selection.verdict, SelectionVerdict::kRedundant);
  EXPECT_FALSE(redundant.keyframe);
  EXPECT_EQ(detector.database().size(), 1u);
}

TEST(LoopDetector, BadInputIsRefusedWithATypedErrorAndChangesNothing) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 5; ++i) feed(&detector, i, i);
  const size_t stored = detector.database().size();
  const double nan = std::numeric_limits<double>::quiet_NaN();

  auto expectRefused = [&](const FrameResult& result, InputErrorCode code) {
    ASSERT_TRUE(result.admission.error);
    EXPECT_EQ(result.admission.error->code, code) << result.admission.error->message;
    EXPECT_FALSE(result.keyframe);
    EXPECT_EQ(detector.database().size(), stored);
  };
  expectRefused(detector.process(10, planarPose(nan, 0, 0), place(1)),
                InputErrorCode::kNonFinitePose);
  Pose unnormalised = planarPose(10, 0, 0);
  unnormalised.orientation.coeffs() *= 3.0;
  expectRefused(detector.process(10, unnormalised, place(1)), InputErrorCode::kNonUnitQuaternion);
  expectRefused(detector.process(3.5, planarPose(10, 0, 0), place(1)),
                InputErrorCode::kStampNotIncreasing);
  expectRefused(detector.process(4.0, planarPose(10, 0, 0), place(1)),
                InputErrorCode::kStampNotIncreasing);
  expectRefused(detector.process(nan, planarPose(10, 0, 0), place(1)),
                InputErrorCode::kNonFiniteStamp);
  expectRefused(detector.process(10, planarPose(10, 0, 0), cv::Mat()), InputErrorCode::kEmptyImage);
  expectRefused(detector.process(10, planarPose(10, 0, 0), cv::Mat(96, 128, CV_8UC1)),
                InputErrorCode::kImageSizeChanged);
  expectRefused(detector.process(10, planarPose(10, 0, 0), cv::Mat(48, 64, CV_32FC1)),
                InputErrorCode::kUnsupportedImageType);

  // The selector's reference is still keyframe 4 at x = 4: x = 4.2 is redundant, x = 5 is not.
  EXPECT_EQ(detector.process(11, planarPose(4.2, 0, 0), place(1)).admission.selection.verdict,
            SelectionVerdict::kRedundant);
  const FrameResult next = detector.process(12, planarPose(5, 0, 0), place(1));
  ASSERT_TRUE(next.keyframe);
  EXPECT_FALSE(next.keyframe->error);
  EXPECT_EQ(next.keyframe->keyframe_id, 5u);
  EXPECT_EQ(detector.database().size(), stored + 1);
}

TEST(LoopDetector, AddKeyframeRefusesAnEmptyImageWithoutStoring) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  const FrameAdmission admission = detector.admit(1.0, planarPose(0, 0, 0), 64, 48, CV_8UC1);
  ASSERT_TRUE(admission.isKeyframe());
  const KeyframeResult result = detector.addKeyframe(admission.keyframe_id, 1.0, Pose{}, cv::Mat());
  ASSERT_TRUE(result.error);
  EXPECT_EQ(result.error->code, InputErrorCode::kEmptyImage);
  EXPECT_TRUE(detector.database().empty());
}

TEST(LoopDetector, InvalidOptionsAreRefusedAtConstruction) {
  LoopDetectorOptions options;
  options.acceptance.consistent_keyframes = 0;
  EXPECT_THROW(LoopDetector(options, std::make_shared<PlaceExtractor>()), std::invalid_argument);
  EXPECT_THROW(LoopDetector(LoopDetectorOptions{}, nullptr), std::invalid_argument);
}

TEST(LoopDetector, KeepsThumbnailsOnlyWhenAsked) {
  LoopDetectorOptions options = smallOptions();
  options.keep_thumbnails = false;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  feed(&detector, 0, 3);
  EXPECT_TRUE(detector.database().record(0)->thumbnail.empty());
  LoopDetector with_thumbnails(smallOptions(), std::make_shared<PlaceExtractor>());
  feed(&with_thumbnails, 0, 3);
  EXPECT_EQ(decodeThumbnail(with_thumbnails.database().record(0)->thumbnail).size(),
            cv::Size(160, 120));
}

TEST(LoopDetector, ABlackKeyframeIsRefusedAndNothingStoredChanges) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  const FrameResult black =
      detector.process(12, planarPose(12, 0, 0), cv::Mat(48, 64, CV_8UC1, cv::Scalar(0)));
  ASSERT_TRUE(black.keyframe);
  ASSERT_TRUE(black.keyframe->error);
  EXPECT_EQ(black.keyframe->error->code, InputErrorCode::kNoTexture);
  EXPECT_FALSE(black.keyframe->stored);
  EXPECT_EQ(detector.database().size(), 12u);
  EXPECT_TRUE(feed(&detector, 13, 13).keyframe->stored);  // And carries on.
}

TEST(LoopDetector, PastTheMemoryBudgetWithoutAMapFileKeyframesAreSearchedButNotStored) {
  LoopDetector probe(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&probe, i, i);
  LoopDetectorOptions options = smallOptions();
  options.database.memory_budget_mb = static_cast<double>(probe.database().bytes()) / 1e6;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) EXPECT_TRUE(feed(&detector, i, i).keyframe->stored) << i;
  EXPECT_TRUE(detector.map().overMemoryBudget());
  // The map still closes loops; nothing more is added.
  FrameResult last;
  for (int i = 40; i < 43; ++i) {
    last = feed(&detector, i, i - 30);
    EXPECT_FALSE(last.keyframe->stored) << i;
  }
  ASSERT_TRUE(last.keyframe->loop);
  EXPECT_EQ(last.keyframe->loop->match_id, 12u);
  EXPECT_EQ(detector.database().size(), 40u);
  options.database.memory_budget_mb = -1.0;
  EXPECT_NE(options.validate().find("advanced/database/memory_budget_mb"), std::string::npos);
}

TEST(LoopDetector, OdometryGateRefusesALoopTheOdometryCannotHaveDriftedInto) {
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  // Places 10-12 seen again 30 m further on, after 30 m of straight travel: at most
  // 1 + 0.1 * 30 = 4 m of drift, 30 - 4 = 26 m of correction needed.
  for (int i = 40; i < 43; ++i) {
    const FrameResult result = feed(&detector, i, i - 30);
    ASSERT_TRUE(result.keyframe);
    EXPECT_FALSE(result.keyframe->loop);
    ASSERT_FALSE(result.keyframe->candidates.empty());
    const CandidateReport& best = result.keyframe->candidates[0];
    EXPECT_EQ(best.match_id, static_cast<uint64_t>(i - 30));
    EXPECT_EQ(best.verdict, CandidateVerdict::kOdometryRejected);
    EXPECT_NE(best.detail.find("26.0 m correction"), std::string::npos) << best.detail;
    EXPECT_NE(best.detail.find("4.0 m"), std::string::npos) << best.detail;
  }
}

TEST(LoopDetector, OdometryGateKeepsALoopWithinTheDriftModel) {
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  // Out along x for 20 m, then back along y = 2 m, past the start: the places seen on the way
  // out are seen again 2 m to the side (within the view distance) after ~40 m of travel.
  for (int i = 0; i < 20; ++i) detector.process(i, planarPose(i, 0, 0), place(i));
  std::optional<AcceptedLoop> loop;
  for (int i = 20; i < 40; ++i) {
    const double x = 39 - i;
    const FrameResult result = detector.process(i, planarPose(x, 2.0, M_PI), place(39 - i));
    if (result.keyframe && result.keyframe->loop) loop = result.keyframe->loop;
    for (const CandidateReport& report : result.keyframe->candidates) {
      EXPECT_NE(report.verdict, CandidateVerdict::kOdometryRejected) << report.detail;
    }
  }
  ASSERT_TRUE(loop);
}

TEST(OdometryGate, AllowanceGrowsWithPathAndTurning) {
  OdometryGateOptions options;
  PathLength start;
  const Pose origin = planarPose(0, 0, 0);
  PathLength path = extendPath(start, origin, planarPose(10, 0, M_PI / 2));
  EXPECT_DOUBLE_EQ(path.metres, 10.0);
  EXPECT_NEAR(path.radians, M_PI / 2, 1e-12);
  // 10 m apart by odometry: 6 m beyond the 4 m view distance; allowed 1 + 1 + 0.5 * pi / 2.
  const OdometryGateDecision decision =
      checkOdometry(options, planarPose(10, 0, 0), path, origin, start);
  EXPECT_NEAR(decision.implied_correction_m, 6.0, 1e-12);
  EXPECT_NEAR(decision.allowed_drift_m, 2.0 + 0.25 * M_PI, 1e-12);
  EXPECT_FALSE(decision.consistent);
  EXPECT_FALSE(decision.reason().empty());
  options.enabled = false;
  EXPECT_TRUE(checkOdometry(options, planarPose(10, 0, 0), path, origin, start).consistent);
  options.drift_per_metre = -1.0;
  options.max_view_distance_m = std::nan("");
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("drift_per_metre"), std::string::npos);
  EXPECT_NE(errors.find("max_view_distance_m"), std::string::npos);
}

TEST(LoopDetector, LocalizationModeSearchesTheMapAddsNothingAndSkipsTheGate) {
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(&detector, i, i);
  ASSERT_EQ(detector.database().size(), 40u);
  // The same revisit the gate refuses in mapping (26 m of correction): a new run's odometry
  // shares nothing with the map's, so localising does not gate.
  detector.setMode(DetectorMode::kLocalization);
  std::optional<AcceptedLoop> loop;
  for (int i = 40; i < 43; ++i) {
    const FrameResult result = feed(&detector, i, i - 30);
    ASSERT_TRUE(result.keyframe);
    EXPECT_FALSE(result.keyframe->error);
    for (const CandidateReport& report : result.keyframe->candidates) {
      EXPECT_NE(report.verdict, CandidateVerdict::kOdometryRejected);
    }
    if (result.keyframe->loop) loop = result.keyframe->loop;
  }
  ASSERT_TRUE(loop);
  EXPECT_EQ(loop->query_id, 42u);
  EXPECT_EQ(loop->match_id, 12u);
  EXPECT_EQ(detector.database().size(), 40u);
  // The map's last keyframes are candidates too: they are not this run's recent past.
  bool searched_latest = false;
  for (int i = 43; i < 46; ++i) {
    const FrameResult result = feed(&detector, i, 39);
    for (const CandidateReport& report : result.keyframe->candidates) {
      searched_latest |= report.match_id == 39u;
    }
  }
  EXPECT_TRUE(searched_latest);
  EXPECT_EQ(detector.database().size(), 40u);

  detector.setMode(DetectorMode::kMapping);
  feed(&detector, 46, 46);
  EXPECT_EQ(detector.database().size(), 41u);
  EXPECT_EQ(detector.database().record(40)->id, 46u);
}

namespace {

// A detector counting consistency in metres, after 40 keyframes 1 m apart showing places 0-39.
std::unique_ptr<LoopDetector> mappedInMetres(double consistent_distance_m) {
  LoopDetectorOptions options = smallOptions();
  options.acceptance.consistency_unit = ConsistencyUnit::kMetres;
  options.acceptance.consistent_distance_m = consistent_distance_m;
  options.acceptance.match_window_m = 0.5;
  auto detector = std::make_unique<LoopDetector>(options, std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 40; ++i) feed(detector.get(), i, i);
  return detector;
}

}  // namespace

TEST(LoopDetector, MetreConsistencyWaitsForTheDistanceNotTheKeyframeCount) {
  const std::unique_ptr<LoopDetector> detector_in_metres = mappedInMetres(2.5);
  LoopDetector& detector = *detector_in_metres;
  // Keyframes 1 m apart: three consistent keyframes cover 2 m, not yet 2.5.
  for (int i = 40; i < 43; ++i) {
    const FrameResult result = feed(&detector, i, i - 30);
    EXPECT_FALSE(result.keyframe->loop);
    const CandidateReport& best = result.keyframe->candidates[0];
    EXPECT_EQ(best.verdict, CandidateVerdict::kAwaitingConsistency);
    EXPECT_NE(best.detail.find(" of 2.50 m"), std::string::npos) << best.detail;
  }
  const FrameResult fourth = feed(&detector, 43, 13);
  ASSERT_TRUE(fourth.keyframe->loop);
  EXPECT_EQ(fourth.keyframe->loop->match_id, 13u);
  EXPECT_EQ(fourth.keyframe->loop->consistent_keyframes, 4);
}

TEST(LoopDetector, MetreConsistencyIsBrokenByAJumpAlongTheOldPath) {
  const std::unique_ptr<LoopDetector> detector_in_metres = mappedInMetres(1.5);
  LoopDetector& detector = *detector_in_metres;
  // Matches hopping 5 m along the old path per 1 m of travel are not one stretch of the map.
  for (int i = 40; i < 45; ++i) {
    EXPECT_FALSE(feed(&detector, i, 5 * (i - 40)).keyframe->loop);
  }
}

TEST(LoopDetector, AcceptanceOptionsAreValidated) {
  LoopDetectorOptions options;
  options.acceptance.consistent_distance_m = -1.0;
  options.acceptance.match_window_m = std::numeric_limits<double>::quiet_NaN();
  options.acceptance.min_score = -0.5;  // Would accept every candidate.
  const std::string problems = options.validate();
  for (const char* key : {"consistent_distance_m", "match_window_m", "min_score"}) {
    EXPECT_NE(problems.find(key), std::string::npos) << key << "\n" << problems;
  }
}

// With advanced/descriptor/condition_window on, what is searched and stored is each keyframe's
// vector less the mean of the last N keyframes: a revisit still finds its place (its own part
// stays), and the window is part of the identity a map is checked against.
TEST(LoopDetector, ConditionWindowStandardisesWhatIsSearchedAndStored) {
  LoopDetectorOptions options = smallOptions();
  options.descriptor.condition_window = 4;
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  EXPECT_NE(detector.descriptorIdentity().find("condition_window=4"), std::string::npos);
  ConditionStandardiser expected(4);
  const PlaceExtractor places;
  std::vector<std::vector<float>> raw;
  for (int i = 0; i < 30; ++i) {
    const FrameResult result = feed(&detector, i, i);
    ASSERT_TRUE(result.keyframe && result.keyframe->stored) << i;
    raw.push_back(places.describe(place(i)).global);
    const std::vector<float> standardised = expected.apply(raw.back());
    // The first three wait for a full window (test_loop_detector_map has the details) ...
    if (i < 3) {
      EXPECT_EQ(detector.database().size(), 0u) << i;
      continue;
    }
    // ... and are then described by it.
    for (int k = 0; i == 3 && k < 3; ++k) {
      const std::shared_ptr<const KeyframeRecord> early = detector.database().record(k);
      ASSERT_TRUE(early);
      EXPECT_GT(cosineSimilarity(early->descriptor.global, expected.standardise(raw[k])), 0.99)
          << k;
    }
    const std::shared_ptr<const KeyframeRecord> record = detector.database().record(i);
    ASSERT_TRUE(record);
    // The database keeps 8 bits per value of the standardised vector, not the raw one.
    EXPECT_GT(cosineSimilarity(record->descriptor.global, standardised), 0.99) << i;
    EXPECT_LT(cosineSimilarity(record->descriptor.global, raw.back()), 0.9) << i;
  }
  // Revisiting places 10-12 after the window has moved on: the chain forms and the loop is found.
  feed(&detector, 30, 10);
  feed(&detector, 31, 11);
  const FrameResult revisit = feed(&detector, 32, 12);
  ASSERT_TRUE(revisit.keyframe->loop);
  EXPECT_EQ(revisit.keyframe->loop->match_id, 12u);
}

// fuzz_loop_detector's kept inputs (issue 67 point 4): images, depths, poses and intrinsics of any
// kind through admit() and addKeyframe(), replayed on every test run; the clean lap must still
// reach loops, or the fuzzer would start from inputs that never get past search.
TEST(LoopDetector, KeptFuzzInputsOfTheWorkerPathNeitherCrashNorBreakAnInvariant) {
  const std::vector<KeptFuzzInput> inputs = keptFuzzInputs("fuzz_loop_detector");
  ASSERT_GE(inputs.size(), 3u);
  for (const KeptFuzzInput& input : inputs) {
    fuzz::LoopDetectorReplay reached;
    EXPECT_TRUE(fuzz::replayLoopDetectorInput(input.bytes.data(), input.bytes.size(), &reached))
        << input.path;
    EXPECT_GT(reached.keyframes, 0) << input.path;
    if (input.path.filename() == "two_laps_grey") {
      EXPECT_GE(reached.keyframes, 25) << input.path;
      EXPECT_GE(reached.loops, 1) << input.path;
    }
  }
}
