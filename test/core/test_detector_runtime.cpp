// The runtime without ROS: keyframes reach the worker in order and give the offline detector's
// loops, a full queue drops the oldest while the caller never waits, time jumping back is refused
// or starts a new timeline (stale keyframes dropped), refused jobs are reported, and the map
// services run between keyframes.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::test_support;

namespace {

// Records what the runtime reports; prepare() can be held closed to keep the worker busy.
class Recorder {
 public:
  RuntimeListener listener() {
    RuntimeListener listener;
    listener.prepare = [this](const KeyframeJob& job, bool, PreparedKeyframe* prepared,
                              InputError* error) {
      std::unique_lock<std::mutex> lock(mutex_);
      ++preparing_;
      changed_.notify_all();
      changed_.wait(lock, [this] { return open_; });
      const cv::Mat& image = std::any_cast<const cv::Mat&>(job.source);
      if (image.empty()) {
        *error = {InputErrorCode::kUnsupportedImageType, "empty test image"};
        return false;
      }
      prepared->image = prepared->grey = image;
      return true;
    };
    listener.rejected = [this](const InputError& error) {
      const std::lock_guard<std::mutex> lock(mutex_);
      rejected_.push_back(error.code);
      ++done_;
      changed_.notify_all();
    };
    listener.timeline_reset = [this] {
      const std::lock_guard<std::mutex> lock(mutex_);
      ++resets_;
    };
    listener.keyframe = [this](const KeyframeJob& job, const KeyframeResult& result,
                               const PreparedKeyframe&) {
      const std::lock_guard<std::mutex> lock(mutex_);
      processed_.push_back(job.id);
      if (result.loop) loops_.emplace_back(job.id, result.loop->match_id);
      ++done_;
      changed_.notify_all();
    };
    return listener;
  }

  void close() {
    const std::lock_guard<std::mutex> lock(mutex_);
    open_ = false;
  }
  void open() {
    const std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  /// Waits until `count` jobs entered prepare(), or `done` jobs finished; false after 10 s.
  bool waitPreparing(int count) {
    return waitFor([&] { return preparing_ >= count; });
  }
  bool waitDone(int count) {
    return waitFor([&] { return done_ >= count; });
  }

  std::vector<uint64_t> processed() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return processed_;
  }
  std::vector<std::pair<uint64_t, uint64_t>> loops() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return loops_;
  }
  std::vector<InputErrorCode> rejected() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return rejected_;
  }
  int resets() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return resets_;
  }

 private:
  bool waitFor(const std::function<bool()>& condition) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(10), condition);
  }

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = true;
  int preparing_ = 0;
  int done_ = 0;
  int resets_ = 0;
  std::vector<uint64_t> processed_;
  std::vector<std::pair<uint64_t, uint64_t>> loops_;
  std::vector<InputErrorCode> rejected_;
};

// Frame i: x = i metres, stamp `stamp` (default i s), showing place `value`.
FrameInput frame(int i, int value, double stamp = -1.0) {
  FrameInput input;
  input.stamp = stamp < 0 ? i : stamp;
  input.pose = planarPose(i, 0, 0);
  const cv::Mat image = place(value);
  input.width = image.cols;
  input.height = image.rows;
  input.cv_type = image.type();
  input.source = image;
  return input;
}

std::unique_ptr<LoopDetector> smallDetector() {
  return std::make_unique<LoopDetector>(smallOptions(), std::make_shared<PlaceExtractor>());
}

}  // namespace

TEST(DetectorRuntime, KeyframesReachTheWorkerInOrderWithTheOfflineDetectorsLoops) {
  // 20 places, then the first 10 again further along the line.
  std::vector<int> places;
  for (int i = 0; i < 20; ++i) places.push_back(i * 10);
  for (int i = 0; i < 10; ++i) places.push_back(i * 10);

  std::vector<std::pair<uint64_t, uint64_t>> offline_loops;
  const std::unique_ptr<LoopDetector> offline = smallDetector();
  for (size_t i = 0; i < places.size(); ++i) {
    const FrameResult result = feed(offline.get(), static_cast<int>(i), places[i]);
    if (result.keyframe && result.keyframe->loop) {
      offline_loops.emplace_back(result.keyframe->keyframe_id, result.keyframe->loop->match_id);
    }
  }
  ASSERT_FALSE(offline_loops.empty());

  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  RuntimeOptions options;
  options.queue_size = 100;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  for (size_t i = 0; i < places.size(); ++i) {
    const RuntimeAdmission admitted = runtime.admit(frame(static_cast<int>(i), places[i]));
    EXPECT_TRUE(admitted.queued);
    EXPECT_FALSE(admitted.dropped_oldest);
  }
  ASSERT_TRUE(recorder.waitDone(static_cast<int>(places.size())));
  const std::vector<uint64_t> processed = recorder.processed();
  EXPECT_TRUE(std::is_sorted(processed.begin(), processed.end()));
  EXPECT_EQ(processed.size(), places.size());
  EXPECT_EQ(recorder.loops(), offline_loops);
  EXPECT_EQ(runtime.keyframesDropped(), 0u);
  EXPECT_GT(runtime.maxProcessingMs(), 0.0);
}

TEST(DetectorRuntime, AFullQueueDropsTheOldestWhileTheCallerNeverWaits) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  recorder.close();  // The worker stays busy with the first keyframe.
  RuntimeOptions options;
  options.queue_size = 2;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  runtime.admit(frame(0, 0));
  ASSERT_TRUE(recorder.waitPreparing(1));
  int dropped = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 1; i < 6; ++i) dropped += runtime.admit(frame(i, i * 10)).dropped_oldest ? 1 : 0;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  EXPECT_EQ(dropped, 3);
  EXPECT_EQ(runtime.keyframesDropped(), 3u);
  EXPECT_EQ(runtime.queued(), 2u);
  recorder.open();
  ASSERT_TRUE(recorder.waitDone(3));
  const std::vector<uint64_t> processed = recorder.processed();
  ASSERT_EQ(processed.size(), 3u);
  EXPECT_LT(processed[0], processed[1]);
  EXPECT_LT(processed[1], processed[2]);
  EXPECT_EQ(detector->database().size(), 3u) << "the in-hand keyframe and the two newest";
}

TEST(DetectorRuntime, TimeJumpingBackIsRefusedByDefault) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, recorder.listener());
  for (int i = 0; i < 5; ++i) runtime.admit(frame(i, i * 10, 100.0 + i));
  const RuntimeAdmission back = runtime.admit(frame(5, 50, 50.0));
  ASSERT_TRUE(back.admission.error);
  EXPECT_EQ(back.admission.error->code, InputErrorCode::kStampNotIncreasing);
  EXPECT_FALSE(back.timeline_restarted_after_s);
  ASSERT_TRUE(recorder.waitDone(5));
  EXPECT_EQ(recorder.resets(), 0);
  EXPECT_EQ(detector->database().size(), 5u);
}

TEST(DetectorRuntime, AFrameStampedAheadOfTheClockIsRefusedAndCannotWedgeLaterFrames) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  RuntimeOptions options;
  options.max_stamp_ahead_s = 5.0;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  const auto at = [](FrameInput input, double clock) {
    input.clock = clock;
    return input;
  };
  for (int i = 0; i < 5; ++i)
    EXPECT_TRUE(runtime.admit(at(frame(i, i * 10, 100.0 + i), 100.0 + i)).queued);
  // A day ahead (a wrong clock on the sender): refused before it can become a keyframe.
  const RuntimeAdmission future = runtime.admit(at(frame(5, 50, 100.0 + 86400.0), 105.0));
  ASSERT_TRUE(future.admission.error);
  EXPECT_EQ(future.admission.error->code, InputErrorCode::kStampInFuture);
  EXPECT_NE(future.admission.error->message.find("ahead of the clock"), std::string::npos);
  // Frames after it go on as before.
  EXPECT_TRUE(runtime.admit(at(frame(6, 60, 106.0), 106.0)).queued);
  // Within the tolerance, or with no clock yet (simulated time not started): admitted.
  EXPECT_TRUE(runtime.admit(at(frame(7, 70, 110.0), 107.0)).queued);
  EXPECT_TRUE(runtime.admit(at(frame(8, 80, 111.0), 0.0)).queued);
  ASSERT_TRUE(recorder.waitDone(8));
  EXPECT_EQ(detector->database().size(), 8u);
}

TEST(DetectorRuntime, AKeyframeWithAWrongStampCannotWedgeLaterFramesForLong) {
  for (const TimeJumpPolicy policy : {TimeJumpPolicy::kDrop, TimeJumpPolicy::kReset}) {
    SCOPED_TRACE(policy == TimeJumpPolicy::kDrop ? "drop" : "reset");
    const std::unique_ptr<LoopDetector> detector = smallDetector();
    Recorder recorder;
    RuntimeOptions options;
    options.time_jump_frames = 5;
    options.time_jump_back = policy;
    options.time_jump_back_s = 1e6;  // A day back is not "far": only the run of frames tells.
    DetectorRuntime runtime(detector.get(), options, recorder.listener());
    for (int i = 0; i < 5; ++i) EXPECT_TRUE(runtime.admit(frame(i, i * 10, 100.0 + i)).queued);
    // No clock to check it against (simulated time not started): a day ahead becomes a keyframe.
    EXPECT_TRUE(runtime.admit(frame(5, 50, 100.0 + 86400.0)).queued);
    ASSERT_TRUE(recorder.waitDone(6));
    // Every later frame is "not after the last keyframe": four are dropped, the fifth is a time
    // jump and starts a new timeline.
    for (int i = 6; i < 10; ++i) {
      const RuntimeAdmission refused = runtime.admit(frame(i, i * 10, 100.0 + i));
      ASSERT_TRUE(refused.admission.error) << i;
      EXPECT_EQ(refused.admission.error->code, InputErrorCode::kStampNotIncreasing);
      EXPECT_FALSE(refused.time_jump_after_frames_s);
    }
    const RuntimeAdmission jump = runtime.admit(frame(10, 100, 110.0));
    ASSERT_TRUE(jump.time_jump_after_frames_s);
    EXPECT_NEAR(*jump.time_jump_after_frames_s, 86400.0 - 10.0, 1e-6);
    EXPECT_FALSE(jump.timeline_restarted_after_s);
    EXPECT_EQ(jump.map_forgotten, policy == TimeJumpPolicy::kReset);
    EXPECT_TRUE(jump.queued);
    EXPECT_TRUE(runtime.admit(frame(11, 110, 111.0)).queued);
    ASSERT_TRUE(recorder.waitDone(8));
    EXPECT_EQ(runtime.timeJumps(), 1u);
    EXPECT_EQ(detector->database().size(), policy == TimeJumpPolicy::kDrop ? 8u : 2u);
    EXPECT_EQ(recorder.resets(), policy == TimeJumpPolicy::kDrop ? 0 : 1);
  }
}

TEST(DetectorRuntime, RestartingTheTimelineLetsEarlierStampsInAfterAReset) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, recorder.listener());
  for (int i = 0; i < 5; ++i) runtime.admit(frame(i, i * 10, 100.0 + i));
  ASSERT_TRUE(recorder.waitDone(5));
  // ~reset: the map is forgotten and the old timeline's stamps no longer bound new ones.
  runtime.withDetector([](LoopDetector& held) {
    held.map().reset();
    return true;
  });
  runtime.restartTimeline();
  EXPECT_TRUE(runtime.admit(frame(0, 0, 10.0)).queued) << "refused as before the old keyframes";
  EXPECT_TRUE(runtime.admit(frame(1, 10, 11.0)).queued);
  ASSERT_TRUE(recorder.waitDone(7));
  EXPECT_EQ(detector->database().size(), 2u);
}

TEST(DetectorRuntime, KeyframesQueuedBeforeAMapIsReplacedAreDroppedAndCounted) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  RuntimeOptions options;
  options.queue_size = 10;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  for (int i = 0; i < 4; ++i) runtime.admit(frame(i, i * 10, 100.0 + i));
  ASSERT_TRUE(recorder.waitDone(4));
  // While a service holds the detector, the camera goes on: three keyframes are queued against
  // the map the service then replaces (~reset or ~load_database).
  const size_t dropped = runtime.withDetector([&](LoopDetector& held) {
    for (int i = 4; i < 7; ++i) EXPECT_TRUE(runtime.admit(frame(i, i * 10, 100.0 + i)).queued);
    held.map().reset();
    return true;
  });
  EXPECT_GE(dropped, 2u) << "the worker may hold one of them, waiting for the detector";
  EXPECT_LE(dropped, 3u);
  runtime.restartTimeline();
  EXPECT_TRUE(runtime.admit(frame(0, 70, 10.0)).queued);
  EXPECT_TRUE(runtime.admit(frame(1, 80, 11.0)).queued);
  ASSERT_TRUE(recorder.waitDone(6));
  EXPECT_EQ(runtime.keyframesDroppedAtMapSwitch(), 3u);
  EXPECT_EQ(detector->database().size(), 2u) << "only keyframes taken after the reset";
  EXPECT_TRUE(recorder.rejected().empty()) << "dropped as queued before the switch, not refused";
  // A service that leaves the map as it was (a save) drops nothing.
  EXPECT_EQ(runtime.withDetector([](LoopDetector&) { return false; }), 0u);
}

TEST(DetectorRuntime, TimeJumpingBackWithResetStartsANewTimelineAndDropsStaleKeyframes) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  recorder.close();
  RuntimeOptions options;
  options.queue_size = 10;
  options.time_jump_back = TimeJumpPolicy::kReset;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  runtime.admit(frame(0, 0, 100.0));
  ASSERT_TRUE(recorder.waitPreparing(1));  // In hand: it belongs to the old timeline.
  runtime.admit(frame(1, 10, 101.0));
  runtime.admit(frame(2, 20, 102.0));  // Queued: dropped as stale.
  const RuntimeAdmission jump = runtime.admit(frame(3, 30, 10.0));
  ASSERT_TRUE(jump.timeline_restarted_after_s);
  EXPECT_NEAR(*jump.timeline_restarted_after_s, 92.0, 1e-9);
  EXPECT_TRUE(jump.queued);
  // A small step back stays refused: it is jitter, not a new timeline.
  const RuntimeAdmission jitter = runtime.admit(frame(4, 40, 9.5));
  ASSERT_TRUE(jitter.admission.error);
  EXPECT_FALSE(jitter.timeline_restarted_after_s);
  recorder.open();
  // The keyframe in hand was prepared for the old timeline: dropped as stale with the queued
  // ones (before images were prepared with the detector free, it was stored, then forgotten).
  ASSERT_TRUE(recorder.waitDone(1));
  EXPECT_EQ(recorder.resets(), 1);
  EXPECT_EQ(runtime.staleKeyframesDropped(), 3u);
  EXPECT_EQ(detector->database().size(), 1u) << "only the new timeline's keyframe";
}

TEST(DetectorRuntime, RefusedJobsAreReportedAndStoreNothing) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, recorder.listener());
  FrameInput broken = frame(0, 0);
  broken.source = cv::Mat();
  runtime.admit(std::move(broken));
  runtime.admit(frame(1, 10));
  ASSERT_TRUE(recorder.waitDone(2));
  ASSERT_EQ(recorder.rejected().size(), 1u);
  EXPECT_EQ(recorder.rejected()[0], InputErrorCode::kUnsupportedImageType);
  EXPECT_EQ(detector->database().size(), 1u);
}

// The odometry comes back 100 m away after tracking was lost: the re-anchored keyframe reaches the
// worker with its mark, and the keyframes after it are a new session even though that keyframe
// itself was refused.
TEST(DetectorRuntime, KeyframesAfterTheOdometryWasReinitialisedAreANewSession) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  const int reanchor_frames = smallOptions().keyframe.jump_reanchor_frames;
  Recorder recorder;
  RuntimeOptions options;
  options.queue_size = 100;
  DetectorRuntime runtime(detector.get(), options, recorder.listener());
  for (int i = 0; i < 5; ++i) runtime.admit(frame(i, i * 10));
  int frames = 5;
  for (int jumped = 0; jumped < reanchor_frames; ++jumped, ++frames) {
    EXPECT_EQ(runtime.admit(frame(100 + frames, 50)).admission.selection.verdict,
              SelectionVerdict::kOdometryJump);
  }
  FrameInput reanchored = frame(100 + frames++, 60);
  reanchored.source = cv::Mat();  // Refused by the worker.
  const RuntimeAdmission admitted = runtime.admit(std::move(reanchored));
  EXPECT_TRUE(admitted.admission.selection.reanchored);
  runtime.admit(frame(100 + frames++, 70));
  runtime.admit(frame(100 + frames++, 80));
  ASSERT_TRUE(recorder.waitDone(8));
  EXPECT_EQ(recorder.rejected().size(), 1u);
  std::vector<uint32_t> sessions;
  runtime.withDetector([&](LoopDetector& worker_detector) {
    for (size_t i = 0; i < worker_detector.database().size(); ++i) {
      sessions.push_back(worker_detector.database().summary(i).session);
    }
    return false;
  });
  EXPECT_EQ(sessions, (std::vector<uint32_t>{0, 0, 0, 0, 0, 1, 1}));
}

TEST(DetectorRuntime, MapServicesRunBetweenKeyframesAndStopIsFinal) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, recorder.listener());
  for (int i = 0; i < 4; ++i) runtime.admit(frame(i, i * 10));
  ASSERT_TRUE(recorder.waitDone(4));
  size_t forgotten = 0;
  runtime.withDetector([&](LoopDetector& held) {
    forgotten = held.database().size();
    held.map().reset();
    return true;
  });
  EXPECT_EQ(forgotten, 4u);
  EXPECT_EQ(detector->database().size(), 0u);
  runtime.stop();
  runtime.stop();  // Idempotent, as the destructor calls it again.
  EXPECT_TRUE(runtime.admit(frame(10, 100)).queued);  // Admitted, never processed.
  EXPECT_EQ(detector->database().size(), 0u);
}

// Preparing a keyframe's images may wait (the depth image, up to 0.2 s): a service gets the
// detector meanwhile, and a map it switches drops the keyframe being prepared.
TEST(DetectorRuntime, AKeyframeBeingPreparedNeverHoldsAServiceBack) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  recorder.close();
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, recorder.listener());
  EXPECT_TRUE(runtime.admit(frame(0, 0)).queued);
  ASSERT_TRUE(recorder.waitPreparing(1));
  EXPECT_TRUE(runtime.tryWithDetector([](LoopDetector&) { return false; }))
      << "the detector is free while images are prepared";
  EXPECT_TRUE(runtime.tryWithDetector([](LoopDetector& held) {
    held.map().reset();
    return true;
  }));
  recorder.open();
  EXPECT_TRUE(runtime.admit(frame(1, 10)).queued);
  ASSERT_TRUE(recorder.waitDone(1));
  EXPECT_EQ(recorder.processed(), std::vector<uint64_t>{1});
  EXPECT_EQ(runtime.keyframesDroppedAtMapSwitch(), 1u);
}

// An exception on the worker (OpenCV, oneDNN, SQLite, a publisher) must not end the process, which
// a shared nodelet manager shares with the camera driver: the job is dropped, counted and reported,
// and the keyframes after it are processed as if it had not come.
TEST(DetectorRuntime, AJobThatThrowsIsReportedAndTheWorkerGoesOn) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  Recorder recorder;
  RuntimeListener listener = recorder.listener();
  const auto prepare = listener.prepare;
  listener.prepare = [prepare](const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                               InputError* error) {
    if (job.id == 1) throw std::runtime_error("oneDNN: could not allocate");
    return prepare(job, colour, prepared, error);
  };
  const auto keyframe = listener.keyframe;
  listener.keyframe = [keyframe](const KeyframeJob& job, const KeyframeResult& result,
                                 const PreparedKeyframe& prepared) {
    keyframe(job, result, prepared);
    if (job.id == 3) throw 42;  // Not even a std::exception.
  };
  std::mutex mutex;
  std::vector<std::pair<uint64_t, std::string>> failures;
  listener.failed = [&](const KeyframeJob& job, const std::string& what) {
    const std::lock_guard<std::mutex> lock(mutex);
    failures.emplace_back(job.id, what);
  };
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, std::move(listener));
  for (int i = 0; i < 6; ++i) runtime.admit(frame(i, i * 10));
  ASSERT_TRUE(recorder.waitDone(5));  // Every job but the one that threw before its result.
  runtime.stop();
  EXPECT_EQ(recorder.processed(), (std::vector<uint64_t>{0, 2, 3, 4, 5}));
  EXPECT_EQ(runtime.keyframesFailed(), 2u);
  const std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(failures.size(), 2u);
  EXPECT_EQ(failures[0].first, 1u);
  EXPECT_EQ(failures[0].second, "oneDNN: could not allocate");
  EXPECT_EQ(failures[1].first, 3u);
  EXPECT_EQ(failures[1].second, "an exception that is not a std::exception");
  EXPECT_EQ(detector->database().size(), 5u)
      << "the job that threw before the detector stored nothing";
}

// The camera mount found while a keyframe is prepared (tf, with the detector free) reaches the
// detector under its lock, so a thread that reads it with the detector held (the fleet link
// expressing a loop in the base frame) never races the worker (issue 82 point 1; scripts/tsan.sh
// runs this test under ThreadSanitizer).
TEST(DetectorRuntime, TheCameraMountFoundWhilePreparingIsGivenWithTheDetectorHeld) {
  const std::unique_ptr<LoopDetector> detector = smallDetector();
  RuntimeListener listener;
  std::atomic<int> done{0};
  listener.prepare = [](const KeyframeJob& job, bool, PreparedKeyframe* prepared, InputError*) {
    prepared->image = prepared->grey = std::any_cast<const cv::Mat&>(job.source);
    // Known from the second keyframe on, as tf's static transform comes a little late.
    prepared->camera_mount =
        job.id == 0 ? std::optional<Pose>() : std::optional<Pose>(planarPose(0.1 * job.id, 0, 0));
    return true;
  };
  listener.keyframe = [&](const KeyframeJob&, const KeyframeResult&, const PreparedKeyframe&) {
    ++done;
  };
  DetectorRuntime runtime(detector.get(), RuntimeOptions{}, listener);
  std::atomic<bool> stop{false};
  std::atomic<double> seen{0.0};
  std::thread reader([&] {
    while (!stop) {
      runtime.withDetector([&](LoopDetector& held) {
        // What expressing a loop in the base frame reads.
        if (held.cameraMount()) seen = held.cameraMount()->position.x();
        return false;
      });
    }
  });
  for (int i = 0; i < 20; ++i) {
    EXPECT_TRUE(runtime.admit(frame(i, 100 + i)).queued);
    while (done < i + 1) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  stop = true;
  reader.join();
  ASSERT_TRUE(detector->cameraMount());
  EXPECT_NEAR(detector->cameraMount()->position.x(), 1.9, 1e-9) << "the last keyframe's mount";
}
