#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <thread>

#include <gtest/gtest.h>

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
  EXPECT_TRUE(detector.overMemoryBudget());
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
  EXPECT_NE(options.validate().find("database/memory_budget_mb"), std::string::npos);
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

namespace {

std::string temporaryPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("lcd_detector_" + name)).string();
}

/// A map file and the write-ahead log SQLite may leave beside it.
void removeMap(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm", "-vectors", "-graph", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
}

}  // namespace

TEST(LoopDetector, ASavedMapIsRecognisedInTheNextSession) {
  const std::string path = temporaryPath("saved_map.lcdb");
  LoopDetectorOptions options = smallOptions();
  options.odometry_gate.enabled = true;
  {
    LoopDetector first_run(options, std::make_shared<PlaceExtractor>());
    for (int i = 0; i < 40; ++i) feed(&first_run, i, i);
    ASSERT_EQ(first_run.saveDatabase(path), "");
  }
  // The next day: the odometry starts again at another origin, stamps go on.
  LoopDetector next_run(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(next_run.loadDatabase(path), "");
  EXPECT_EQ(next_run.database().size(), 40u);
  EXPECT_EQ(next_run.session(), 1u);
  std::optional<AcceptedLoop> loop;
  bool found_the_maps_last_keyframe = false;
  for (int i = 0; i < 3; ++i) {
    const FrameResult result =
        next_run.process(100000.0 + i, planarPose(500.0 + i, 0, 0), place(37 + i));
    ASSERT_TRUE(result.keyframe);
    EXPECT_GE(result.keyframe->keyframe_id, 40u);  // Never an id of the loaded map.
    for (const CandidateReport& report : result.keyframe->candidates) {
      // 500 m from the map's poses, but the map's odometry frame is another run's: no gate.
      EXPECT_NE(report.verdict, CandidateVerdict::kOdometryRejected) << report.detail;
      found_the_maps_last_keyframe |= report.match_id == 39u;
    }
    if (result.keyframe->loop) loop = result.keyframe->loop;
  }
  EXPECT_TRUE(found_the_maps_last_keyframe);  // Not excluded as "recent".
  ASSERT_TRUE(loop);
  EXPECT_EQ(loop->match_id, 39u);
  EXPECT_EQ(loop->match_session, 0u);
  ASSERT_EQ(next_run.database().size(), 43u);
  EXPECT_EQ(next_run.database().record(42)->session, 1u);
  EXPECT_EQ(next_run.database().record(42)->id, 42u);
  removeMap(path);
}

TEST(LoopDetector, ARefusedLoadChangesNothingAndResetForgetsAll) {
  LoopDetector detector(smallOptions(), std::make_shared<PlaceExtractor>());
  for (int i = 0; i < 12; ++i) feed(&detector, i, i);
  const std::string error = detector.loadDatabase(temporaryPath("missing.lcdb"));
  EXPECT_NE(error.find("missing.lcdb"), std::string::npos) << error;
  EXPECT_EQ(detector.database().size(), 12u);
  EXPECT_EQ(detector.session(), 0u);

  // A map made with other descriptors is refused the same way.
  const std::string path = temporaryPath("other_descriptors.lcdb");
  LoopDetectorOptions hog = smallOptions();
  hog.descriptor.type = "hog";
  {
    LoopDetector other(hog, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(other.saveDatabase(path), "");
  }
  EXPECT_NE(detector.loadDatabase(path).find("other descriptors"), std::string::npos);
  EXPECT_EQ(detector.database().size(), 12u);
  removeMap(path);

  detector.reset();
  EXPECT_TRUE(detector.database().empty());
  EXPECT_FALSE(feed(&detector, 12, 12).keyframe->error);
  EXPECT_EQ(detector.database().size(), 1u);
}

TEST(LoopDetector, AnOpenMapHasEveryStoredKeyframeAndAResetKeepsItAside) {
  const std::string path = temporaryPath("open_map.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    EXPECT_EQ(detector.mapPath(), path);
    for (int i = 0; i < 15; ++i) feed(&detector, i, i);
  }  // No save: every keyframe was committed when it was stored.
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  EXPECT_EQ(detector.database().size(), 15u);
  EXPECT_EQ(detector.session(), 1u);

  const std::string note = detector.reset();
  EXPECT_NE(note.find("kept as " + path + ".reset-"), std::string::npos) << note;
  EXPECT_TRUE(detector.database().empty());
  feed(&detector, 20, 20);
  const std::string kept = note.substr(note.find(path));
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 15u) << "the reset map is whole";
  removeMap(path);
  removeMap(kept);
}

TEST(LoopDetector, AMapKeepsItsSearchGraphAndLinksInWhatACrashLeftOut) {
  const std::string path = temporaryPath("graph_map.db");
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.database.index.type = "approximate";
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 12; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    EXPECT_TRUE(detector.mapGraphReused());
    ASSERT_NE(detector.database().graph(), nullptr);
    EXPECT_EQ(detector.database().graph()->size(), 12u);
    feed(&detector, 12, 12);  // Then stopped without saving the graph, as a crash would.
  }
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  // The saved graph misses the last keyframe: reused, and the keyframe linked in.
  EXPECT_TRUE(detector.mapGraphReused());
  ASSERT_NE(detector.database().graph(), nullptr);
  EXPECT_EQ(detector.database().graph()->size(), 13u);
  removeMap(path);
}

TEST(LoopDetector, PastTheMemoryBudgetAMapKeepsGrowingOnDiskAndItsNextStartSearchesItAll) {
  const std::string probe_path = temporaryPath("budget_probe.db");
  const std::string path = temporaryPath("budget_map.db");
  removeMap(probe_path);
  removeMap(path);
  LoopDetectorOptions options = smallOptions();
  options.database.index.type = "approximate";
  uint64_t last_written = 0;
  {
    LoopDetector probe(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(probe.openMap(probe_path), "");
    for (int i = 0; i < 40; ++i) feed(&probe, i, i);
    options.database.memory_budget_mb = static_cast<double>(probe.database().bytes()) / 1e6;
  }
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 40; ++i) {
      const KeyframeResult stored = *feed(&detector, i, i).keyframe;
      EXPECT_TRUE(stored.stored && !stored.searched_from_next_start) << i;
    }
    ASSERT_TRUE(detector.overMemoryBudget());
    // Revisits still close loops; the keyframes go to the map, not to search.
    FrameResult last;
    for (int i = 40; i < 45; ++i) {
      last = feed(&detector, i, i - 30);
      EXPECT_TRUE(last.keyframe->stored && last.keyframe->searched_from_next_start) << i;
      EXPECT_TRUE(last.keyframe->store_error.empty()) << last.keyframe->store_error;
    }
    last_written = last.keyframe->keyframe_id;
    ASSERT_TRUE(last.keyframe->loop);
    EXPECT_EQ(last.keyframe->loop->match_id, 14u);
    EXPECT_EQ(detector.database().size(), 40u);
    EXPECT_EQ(detector.saveMapGraph(), "") << "the graph over the searched keyframes is saved";
  }
  EXPECT_EQ(KeyframeStore::openExisting(path)->size(), 45u);
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "");
  ASSERT_EQ(detector.database().size(), 45u);
  EXPECT_EQ(detector.database().summary(44).id, last_written);
  EXPECT_TRUE(detector.mapGraphReused());
  ASSERT_NE(detector.database().graph(), nullptr);
  EXPECT_EQ(detector.database().graph()->size(), 45u) << "the five linked in";
  removeMap(probe_path);
  removeMap(path);
}

TEST(LoopDetector, AMapWhoseSealedRowsTurnOutDamagedStopsSearchAndKeepsCommittingKeyframes) {
  const std::string path = temporaryPath("damaged_rows_map.db");
  removeMap(path);
  const LoopDetectorOptions options = smallOptions();
  {
    LoopDetector detector(options, std::make_shared<PlaceExtractor>());
    ASSERT_EQ(detector.openMap(path), "");
    for (int i = 0; i < 20; ++i) feed(&detector, i, i);
    EXPECT_EQ(detector.saveMapGraph(), "");
  }
  const auto flipFirstRowByte = [](const std::string& map) {
    std::fstream rows(map + "-vectors", std::ios::in | std::ios::out | std::ios::binary);
    rows.seekg(30);
    const char byte = static_cast<char>(rows.get());
    rows.seekp(30);
    rows.put(static_cast<char>(byte ^ 0x5a));
  };
  flipFirstRowByte(path);
  LoopDetector detector(options, std::make_shared<PlaceExtractor>());
  ASSERT_EQ(detector.openMap(path), "") << "search starts while the rows are checked";
  EXPECT_EQ(detector.database().size(), 20u);
  for (int wait = 0; wait < 1000 && detector.mapRowsCheck() == "being checked"; ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(detector.mapRowsCheck(), "damaged");
  // Revisits of places 5..9: nothing searched, no loop, said once; every keyframe still stored.
  for (int i = 20; i < 25; ++i) {
    const KeyframeResult result = *feed(&detector, i, i - 15).keyframe;
    EXPECT_EQ(result.query_status, QueryStatus::kMapDamaged) << i;
    EXPECT_FALSE(result.loop) << i;
    EXPECT_TRUE(result.candidates.empty()) << i;
    EXPECT_TRUE(result.stored && result.store_error.empty()) << i;
    if (i == 20) {
      EXPECT_NE(result.map_damage.find("-vectors are damaged"), std::string::npos)
          << result.map_damage;
    } else {
      EXPECT_EQ(result.map_damage, "") << i;
    }
  }
  EXPECT_NE(detector.mapDamage(), "");
  const std::string note = detector.reset();  // A fresh map: searched again.
  EXPECT_EQ(detector.mapDamage(), "");
  EXPECT_EQ(detector.mapRowsCheck(), "checked");
  // The damaged map, kept aside by the reset, lost nothing: its byte put back, it holds all 25.
  ASSERT_NE(note.find("kept as " + path), std::string::npos) << note;
  const std::string kept = note.substr(note.find(path));
  flipFirstRowByte(kept);
  EXPECT_EQ(KeyframeStore::openExisting(kept)->size(), 25u);
  removeMap(path);
  removeMap(kept);
}
