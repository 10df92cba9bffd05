// A camera that stops while the robot drives on is no odometry reset (issue 80 point 4): the
// odometry held between the last keyframe and the next image tells the two apart, so the session
// (one odometry frame) goes on across the gap, while a real reset still starts a new one.
#include <memory>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/runtime/odometry_history.h"
#include "small_detector.h"

using namespace landmark_loop_closure;
using test_support::PlaceExtractor;

namespace {

constexpr double kSpeed = 8.0 / 12.0;  // 8 m in 12 s.
constexpr double kOdometryPeriod = 0.05;
constexpr double kImagePeriod = 0.1;
constexpr double kMaxInterval = 0.2;  // advanced/odometry_max_interval's default.

struct Drive {
  Drive() : detector(options(), std::make_shared<PlaceExtractor>()) {}
  static LoopDetectorOptions options() {
    LoopDetectorOptions options = test_support::smallOptions();
    options.keyframe = KeyframeSelectorOptions{};  // The shipped rule: max_motion 5, 15 frames.
    return options;
  }
  // Odometry up to `until` at 20 Hz; `offset` moves the odometry's frame (a reset).
  void odometryUntil(double until, double offset = 0.0) {
    for (; clock <= until + 1e-9; clock += kOdometryPeriod) {
      history.add(clock, planarPose(kSpeed * clock + offset, 0, 0));
    }
  }
  FrameResult image(double stamp) {
    const OdometryLookup lookup = history.at(stamp, kMaxInterval);
    EXPECT_EQ(lookup.status, OdometryAt::kFound) << stamp;
    ++frame;
    return detector.process(
        stamp, lookup.pose, test_support::place(frame % 30), {}, {},
        [this, stamp](double since) { return history.posesBetween(since, stamp, kMaxInterval); });
  }
  LoopDetector detector;
  OdometryHistory history{2000};
  double clock = 0.0;
  int frame = 0;
};

}  // namespace

TEST(CameraGap, TwelveSecondsWithoutImagesWhileDriving8MetresKeepsTheSession) {
  Drive drive;
  int jumps = 0;
  int keyframes = 0;
  bool across_gap = false;
  for (double t = 0.0; t < 30.0; t += kImagePeriod) {
    drive.odometryUntil(t + kOdometryPeriod);
    if (t > 10.0 && t < 22.0) continue;  // The camera stops; the odometry goes on.
    const FrameResult result = drive.image(t);
    jumps += result.admission.selection.verdict == SelectionVerdict::kOdometryJump;
    keyframes += result.admission.isKeyframe();
    across_gap = across_gap || result.admission.selection.across_gap;
  }
  EXPECT_EQ(jumps, 0) << "a camera gap is no odometry jump";
  EXPECT_TRUE(across_gap);
  EXPECT_EQ(drive.detector.session(), 0u);
  EXPECT_GT(keyframes, 20);
}

TEST(CameraGap, AnOdometryResetStillStartsANewSession) {
  Drive drive;
  int jumps = 0;
  for (double t = 0.0; t < 20.0; t += kImagePeriod) {
    // At 10 s the odometry re-initialises 20 m back: one step of the odometry itself jumps.
    drive.odometryUntil(t + kOdometryPeriod, drive.clock >= 10.0 ? -20.0 : 0.0);
    const FrameResult result = drive.image(t);
    jumps += result.admission.selection.verdict == SelectionVerdict::kOdometryJump;
    EXPECT_FALSE(result.admission.selection.across_gap) << t;
  }
  EXPECT_EQ(jumps, 15);
  EXPECT_EQ(drive.detector.session(), 1u);
}

TEST(CameraGap, WithoutTheOdometryBetweenAGapIsAJumpAsBefore) {
  KeyframeSelector selector(KeyframeSelectorOptions{});
  EXPECT_EQ(selector.select(0.0, planarPose(0, 0, 0)).verdict, SelectionVerdict::kKeyframe);
  // 8 m later, nothing known between (tf, or the odometry held does not reach back).
  const Selection unknown =
      selector.select(12.0, planarPose(8, 0, 0), [](double) { return std::vector<Pose>(); });
  EXPECT_EQ(unknown.verdict, SelectionVerdict::kOdometryJump);
  EXPECT_EQ(selector.select(12.1, planarPose(8, 0, 0)).verdict, SelectionVerdict::kOdometryJump);
}
