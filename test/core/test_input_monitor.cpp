// The node's input rules without ROS: silent inputs, images that never meet their odometry,
// throttled logging of bad frames, and waiting for a depth image near a keyframe's stamp.
#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "landmark_loop_closure/runtime/input_monitor.h"
#include "landmark_loop_closure/runtime/stamped_buffer.h"

using namespace landmark_loop_closure;

namespace {

InputMonitorOptions monitorOptions() {
  InputMonitorOptions options;
  options.timeout_s = 5.0;
  options.max_interval_s = 0.25;
  options.rejection_log_period_s = 5.0;
  return options;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

TEST(InputMonitor, SilentInputsAreReportedAfterTheTimeout) {
  InputMonitor monitor(monitorOptions(), 100.0);
  EXPECT_TRUE(monitor.imageSilent(106.0)) << "nothing ever came";
  monitor.imageArrived(104.0, 1.0);
  EXPECT_FALSE(monitor.imageSilent(106.0));
  EXPECT_TRUE(monitor.poseSilent(106.0));
  monitor.poseArrived(105.0, 1.0);
  EXPECT_FALSE(monitor.poseSilent(109.9));
  EXPECT_TRUE(monitor.poseSilent(110.1));
  EXPECT_EQ(monitor.images(), 1u);
  EXPECT_EQ(monitor.poses(), 1u);
}

TEST(InputMonitor, UnpairedInputsNameTheirStampsOnlyAfterTheTimeout) {
  InputMonitor monitor(monitorOptions(), 0.0);
  for (double now = 0.0; now <= 8.0; now += 0.5) {
    monitor.imageArrived(now, 1000.0 + now);
    monitor.poseArrived(now, 1003.0 + now);  // Three seconds apart: never within the slop.
  }
  EXPECT_EQ(monitor.unpaired(4.9), "") << "inputs get the timeout to pair";
  const std::string warning = monitor.unpaired(8.0);
  EXPECT_NE(warning.find("newest image stamp 1008.000"), std::string::npos) << warning;
  EXPECT_NE(warning.find("newest odometry stamp 1011.000"), std::string::npos) << warning;
  EXPECT_NE(warning.find("(3.000 s apart)"), std::string::npos) << warning;
  monitor.paired(8.0);
  EXPECT_EQ(monitor.unpaired(8.5), "");
  EXPECT_EQ(monitor.unpaired(30.0), "") << "inputs stopped: that is a silence, not unpaired";
}

TEST(InputMonitor, EachKindOfBadFrameIsLoggedOncePerPeriodAndAllAreCounted) {
  InputMonitor monitor(monitorOptions(), 0.0);
  uint64_t count = 0;
  EXPECT_TRUE(monitor.rejected(InputErrorCode::kEmptyImage, 1.0, &count));
  EXPECT_FALSE(monitor.rejected(InputErrorCode::kEmptyImage, 2.0, &count));
  EXPECT_TRUE(monitor.rejected(InputErrorCode::kNonFinitePose, 2.0, &count)) << "another kind";
  EXPECT_FALSE(monitor.rejected(InputErrorCode::kEmptyImage, 5.9, &count));
  EXPECT_TRUE(monitor.rejected(InputErrorCode::kEmptyImage, 6.0, &count));
  EXPECT_EQ(count, 4u);
  EXPECT_EQ(monitor.rejections().at(InputErrorCode::kEmptyImage), 4u);
  EXPECT_EQ(monitor.rejections().at(InputErrorCode::kNonFinitePose), 1u);
}

TEST(InputMonitor, RatesCountArrivalsSinceTheLastCall) {
  InputMonitor monitor(monitorOptions(), 0.0);
  for (int i = 0; i < 20; ++i) monitor.imageArrived(i * 0.1, i * 0.1);
  for (int i = 0; i < 10; ++i) monitor.poseArrived(i * 0.2, i * 0.2);
  const InputMonitor::Rates first = monitor.takeRates(2.0);
  EXPECT_DOUBLE_EQ(first.image_hz, 10.0);
  EXPECT_DOUBLE_EQ(first.pose_hz, 5.0);
  const InputMonitor::Rates second = monitor.takeRates(4.0);
  EXPECT_DOUBLE_EQ(second.image_hz, 0.0);
}

TEST(StampedBuffer, GivesTheNearestItemWithinTheSlop) {
  StampedBuffer<int> buffer(10);
  buffer.push(10.00, 1);
  buffer.push(10.04, 2);
  buffer.push(10.10, 3);
  StampedWait wait;
  wait.slop_s = 0.05;
  wait.max_wait_s = 1.0;
  EXPECT_EQ(buffer.nearest(10.03, wait, true), 2);
  EXPECT_EQ(buffer.nearest(10.01, wait, true), 1);
  // 10.30 has no match and nothing newer came, but the wait is bounded.
  wait.max_wait_s = 0.05;
  EXPECT_EQ(buffer.nearest(10.30, wait, true), std::nullopt);
}

TEST(StampedBuffer, DoesNotWaitWhenTheMatchCannotComeAnyMore) {
  StampedBuffer<int> buffer(10);
  StampedWait wait;
  wait.max_wait_s = 5.0;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(buffer.nearest(1.0, wait, false), std::nullopt) << "nobody publishes";
  buffer.push(2.0, 1);
  EXPECT_EQ(buffer.nearest(1.0, wait, true), std::nullopt) << "a newer item came first";
  EXPECT_EQ(buffer.nearest(10.0, wait, true), std::nullopt) << "the stream went silent";
  EXPECT_LT(secondsSince(start), 1.0) << "none of these may wait";
}

TEST(StampedBuffer, WaitsForAMatchThatIsStillComing) {
  StampedBuffer<int> buffer(10);
  buffer.push(0.9, 1);
  StampedWait wait;
  wait.slop_s = 0.02;
  wait.max_wait_s = 5.0;
  std::thread producer([&buffer] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    buffer.push(1.01, 7);
  });
  EXPECT_EQ(buffer.nearest(1.0, wait, true), 7);
  producer.join();
}

TEST(StampedBuffer, APublisherThatNeverPublishesCostsOneWaitUntilItemsCome) {
  StampedBuffer<int> buffer(10);
  StampedWait wait;
  wait.slop_s = 0.02;
  wait.max_wait_s = 0.1;
  EXPECT_FALSE(buffer.silent());
  EXPECT_EQ(buffer.nearest(1.0, wait, true), std::nullopt) << "one bounded wait";
  EXPECT_TRUE(buffer.silent());
  wait.max_wait_s = 5.0;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(buffer.nearest(1.1, wait, true), std::nullopt);
  EXPECT_EQ(buffer.nearest(1.2, wait, true), std::nullopt);
  EXPECT_LT(secondsSince(start), 1.0) << "a silent stream is not waited for again";
  buffer.push(1.25, 4);
  EXPECT_FALSE(buffer.silent()) << "an item ends the silence";
  std::thread producer([&buffer] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    buffer.push(1.3, 5);
  });
  EXPECT_EQ(buffer.nearest(1.3, wait, true), 5) << "once items come, a match is waited for again";
  producer.join();
}

TEST(StampedBuffer, KeepsOnlyTheNewestItems) {
  StampedBuffer<int> buffer(3);
  for (int i = 0; i < 10; ++i) buffer.push(i, i);
  EXPECT_EQ(buffer.size(), 3u);
  StampedWait wait;
  wait.max_wait_s = 0.0;
  EXPECT_EQ(buffer.nearest(2.0, wait, true), std::nullopt) << "dropped";
  EXPECT_EQ(buffer.nearest(8.0, wait, true), 8);
}

TEST(StampedBuffer, HoldsTheItemOfAWantedStampAfterItLeavesTheWindow) {
  // A worker 40 items behind a 3-item window still finds the depth image of its keyframe, whether
  // the image came before or after the keyframe was queued.
  StampedBuffer<int> buffer(3);
  buffer.push(1.00, 100);
  buffer.want(1.01, 0.05);
  buffer.want(2.00, 0.05);
  for (int i = 0; i < 40; ++i) buffer.push(1.98 + 0.01 * i, i);
  EXPECT_EQ(buffer.size(), 3u);
  EXPECT_EQ(buffer.wantedCount(), 2u);
  StampedWait wait;
  wait.max_wait_s = 5.0;  // Nothing better can come: later items arrived, so no wait.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(buffer.nearest(1.01, wait, true), 100);
  EXPECT_EQ(buffer.nearest(2.00, wait, true), 2) << "the nearest of those that came, 1.98 + 0.02";
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  EXPECT_EQ(buffer.wantedCount(), 0u) << "an answered stamp is not held any more";
  wait.max_wait_s = 0.0;
  EXPECT_EQ(buffer.nearest(1.01, wait, true), std::nullopt) << "held once, for one consumer";
}

TEST(StampedBuffer, AWantedStampWithoutAMatchGivesNothing) {
  StampedBuffer<int> buffer(3);
  buffer.want(5.0, 0.02);
  for (int i = 0; i < 10; ++i) buffer.push(6.0 + i, i);
  StampedWait wait;
  wait.slop_s = 0.02;
  wait.max_wait_s = 5.0;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(buffer.nearest(5.0, wait, true), std::nullopt);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  EXPECT_EQ(buffer.wantedCount(), 0u);
}

TEST(StampedBuffer, HoldsAtMostMaxWantedStamps) {
  // A consumer that drops queued jobs never asks for them: the oldest stamps are let go.
  StampedBuffer<int> buffer(3, 4);
  for (int i = 0; i < 10; ++i) {
    buffer.push(i, i);
    buffer.want(i, 0.01);
  }
  EXPECT_EQ(buffer.wantedCount(), 4u);
  for (int i = 10; i < 20; ++i) buffer.push(i, i);
  StampedWait wait;
  wait.max_wait_s = 0.0;
  EXPECT_EQ(buffer.nearest(5.0, wait, true), std::nullopt) << "let go";
  EXPECT_EQ(buffer.nearest(6.0, wait, true), 6) << "still held";
  buffer.setMaxWanted(1);
  EXPECT_EQ(buffer.wantedCount(), 1u);
  EXPECT_EQ(buffer.nearest(9.0, wait, true), 9) << "the newest is kept";
}
