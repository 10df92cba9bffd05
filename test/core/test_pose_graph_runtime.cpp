// The pose graph's runtime: inputs from several threads, a worker that reports what throws.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/backend/pose_graph_runtime.h"
#include "pose_graph_fixtures.h"

namespace landmark_loop_closure {
namespace {

using namespace pose_graph_fixtures;

TEST(PoseGraphRuntime, InputsFromSeveralThreadsAllEnterWhileTheCorrectionIsRead) {
  std::mutex mutex;
  std::condition_variable changed;
  size_t keyframes_seen = 0;
  size_t verdicts_seen = 0;
  bool caught_up = false;
  PoseGraphListener listener;
  listener.step = [&](PoseGraphSession& session, const GraphStep& step) {
    std::lock_guard<std::mutex> lock(mutex);
    keyframes_seen = session.graph().keyframes();
    verdicts_seen += step.verdicts.size();
    changed.notify_all();
  };
  listener.catch_up = [&](PoseGraphSession& session) {
    session.pathsPublished();
    std::lock_guard<std::mutex> lock(mutex);
    caught_up = true;
    changed.notify_all();
  };
  PoseGraphRuntime runtime(eachLoopOnItsOwn(), cameraOnly, listener, std::chrono::milliseconds(20));
  EXPECT_FALSE(runtime.correction().has_value());
  constexpr uint64_t kKeyframes = 205;  // Not a multiple of 10: the last paths need a catch-up.
  std::atomic<bool> done{false};
  std::thread keyframe_source([&] {
    for (uint64_t id = 0; id < kKeyframes; ++id) runtime.push(keyframeAt(id));
  });
  std::thread loop_source([&] {
    for (uint64_t query = 100; query < kKeyframes; query += 5) {
      runtime.push(loopBetween(query, query - 100));
    }
  });
  std::thread reader([&] {
    while (!done) {
      const std::optional<GraphCorrection> correction = runtime.correction();
      if (correction) {
        EXPECT_EQ(correction->odometry_frame, "odom");
      }
    }
  });
  keyframe_source.join();
  loop_source.join();
  {
    std::unique_lock<std::mutex> lock(mutex);
    EXPECT_TRUE(changed.wait_for(
        lock, std::chrono::seconds(60),
        [&] { return keyframes_seen == kKeyframes && verdicts_seen >= 21 && caught_up; }))
        << keyframes_seen << " keyframes, " << verdicts_seen << " verdicts";
  }
  done = true;
  reader.join();
  runtime.stop();
  runtime.stop();  // Idempotent.
  ASSERT_TRUE(runtime.correction().has_value());
  EXPECT_NE(runtime.summary().find("205 keyframes"), std::string::npos) << runtime.summary();
}

// An exception on the worker (Ceres, a listener) must not end the process, which a shared nodelet
// manager shares with the detector and the camera driver.
TEST(PoseGraphRuntime, ABatchThatThrowsIsReportedAndTheWorkerGoesOn) {
  std::mutex mutex;
  std::condition_variable changed;
  size_t keyframes_seen = 0;
  bool thrown = false;
  std::vector<std::string> failures;
  PoseGraphListener listener;
  listener.step = [&](PoseGraphSession& session, const GraphStep&) {
    std::lock_guard<std::mutex> lock(mutex);
    keyframes_seen = session.graph().keyframes();
    changed.notify_all();
    if (!thrown) {
      thrown = true;
      throw std::runtime_error("publish failed");
    }
  };
  listener.failed = [&](const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex);
    failures.push_back(what);
    changed.notify_all();
  };
  PoseGraphRuntime runtime(eachLoopOnItsOwn(), cameraOnly, listener, std::chrono::milliseconds(20));
  runtime.push(keyframeAt(0));
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(
        changed.wait_for(lock, std::chrono::seconds(10), [&] { return !failures.empty(); }));
  }
  for (uint64_t id = 1; id < 5; ++id) runtime.push(keyframeAt(id));
  {
    std::unique_lock<std::mutex> lock(mutex);
    EXPECT_TRUE(changed.wait_for(lock, std::chrono::seconds(10), [&] {
      return keyframes_seen == 5;
    })) << keyframes_seen;
  }
  runtime.stop();
  EXPECT_EQ(runtime.failures(), 1u);
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0], "publish failed");
}

}  // namespace
}  // namespace landmark_loop_closure
