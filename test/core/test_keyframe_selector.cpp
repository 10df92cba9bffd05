#include <cmath>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/keyframe_admission.h"
#include "landmark_loop_closure/core/keyframe_selector.h"

using namespace landmark_loop_closure;

namespace {
constexpr double kPi = 3.14159265358979323846;
}

TEST(KeyframeSelector, MotionCombinesTranslationAndRotation) {
  KeyframeSelectorOptions options;
  options.translation_weight = 2.0;
  options.rotation_weight = 3.0;
  const KeyframeSelector selector(options);
  EXPECT_NEAR(selector.motion(planarPose(0, 0, 0), planarPose(3, 4, 0)), 2.0 * 5.0, 1e-9);
  EXPECT_NEAR(selector.motion(planarPose(0, 0, 0), planarPose(0, 0, 0.5)), 3.0 * 0.5, 1e-9);
  // Rotation is measured as the norm of (roll, pitch, yaw) of the relative rotation.
  Pose rolled;
  rolled.orientation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) *
                       Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY());
  const Eigen::Vector3d rpy = rollPitchYaw(rolled.orientation);
  EXPECT_NEAR(selector.motion(Pose{}, rolled), 3.0 * rpy.norm(), 1e-9);
}

TEST(KeyframeSelector, RelativeMotionIgnoresWhereTheLastKeyframeWas) {
  const KeyframeSelector selector(KeyframeSelectorOptions{});
  // The same 1 m forward step, expressed from two different start poses.
  EXPECT_NEAR(selector.motion(planarPose(5, 5, kPi / 2), planarPose(5, 6, kPi / 2)), 1.0, 1e-9);
  // Yaw wrapping: -179 deg to +179 deg is a 2 degree turn, not 358.
  const double a = -179.0 * kPi / 180.0;
  const double b = 179.0 * kPi / 180.0;
  EXPECT_NEAR(selector.motion(planarPose(0, 0, a), planarPose(0, 0, b)), 2.0 * kPi / 180.0, 1e-9);
}

TEST(KeyframeSelector, FirstFrameIsAKeyframe) {
  KeyframeSelector selector(KeyframeSelectorOptions{});
  EXPECT_FALSE(selector.hasKeyframe());
  EXPECT_EQ(selector.select(0.0, planarPose(10, 10, 1)).verdict, SelectionVerdict::kKeyframe);
  EXPECT_TRUE(selector.hasKeyframe());
}

TEST(KeyframeSelector, RejectsRedundantAndJumps) {
  KeyframeSelectorOptions options;
  options.min_motion = 0.5;
  options.max_motion = 3.0;
  KeyframeSelector selector(options);
  selector.select(0.0, planarPose(0, 0, 0));
  const Selection small = selector.select(1.0, planarPose(0.2, 0, 0));
  EXPECT_EQ(small.verdict, SelectionVerdict::kRedundant);
  EXPECT_NEAR(small.motion, 0.2, 1e-9);
  EXPECT_EQ(selector.select(2.0, planarPose(10, 0, 0)).verdict, SelectionVerdict::kOdometryJump);
  // The reference did not move: 0.6 m from the first keyframe makes a keyframe.
  EXPECT_EQ(selector.select(3.0, planarPose(0.6, 0, 0)).verdict, SelectionVerdict::kKeyframe);
  // And the reference is now at 0.6 m.
  EXPECT_EQ(selector.select(4.0, planarPose(0.9, 0, 0)).verdict, SelectionVerdict::kRedundant);
  EXPECT_EQ(selector.select(5.0, planarPose(1.2, 0, 0)).verdict, SelectionVerdict::kKeyframe);
}

TEST(KeyframeSelector, BoundaryValuesAreInside) {
  KeyframeSelectorOptions options;
  options.min_motion = 0.5;
  options.max_motion = 2.0;
  KeyframeSelector selector(options);
  selector.select(0.0, planarPose(0, 0, 0));
  EXPECT_EQ(selector.select(1.0, planarPose(0.5, 0, 0)).verdict, SelectionVerdict::kKeyframe);
  EXPECT_EQ(selector.select(2.0, planarPose(2.5, 0, 0)).verdict, SelectionVerdict::kKeyframe);
}

TEST(KeyframeSelector, TimeGapForcesAKeyframe) {
  KeyframeSelectorOptions options;
  options.max_time_gap = 5.0;
  KeyframeSelector selector(options);
  selector.select(0.0, planarPose(0, 0, 0));
  EXPECT_EQ(selector.select(4.9, planarPose(0, 0, 0)).verdict, SelectionVerdict::kRedundant);
  const Selection forced = selector.select(5.0, planarPose(0, 0, 0));
  EXPECT_EQ(forced.verdict, SelectionVerdict::kKeyframe);
  EXPECT_TRUE(forced.forced_by_time);
}

TEST(KeyframeSelector, TimeGapIsOffByDefault) {
  KeyframeSelector selector(KeyframeSelectorOptions{});
  selector.select(0.0, planarPose(0, 0, 0));
  EXPECT_EQ(selector.select(1e6, planarPose(0, 0, 0)).verdict, SelectionVerdict::kRedundant);
}

TEST(KeyframeSelector, ReanchorsAfterAPersistentJump) {
  KeyframeSelectorOptions options;
  options.jump_reanchor_frames = 3;
  KeyframeSelector selector(options);
  selector.select(0.0, planarPose(0, 0, 0));
  for (int i = 1; i <= 3; ++i) {
    EXPECT_EQ(selector.select(i, planarPose(100, 0, 0)).verdict, SelectionVerdict::kOdometryJump);
  }
  const Selection reanchored = selector.select(4.0, planarPose(100, 0, 0));
  EXPECT_EQ(reanchored.verdict, SelectionVerdict::kKeyframe);
  EXPECT_TRUE(reanchored.reanchored);
  EXPECT_EQ(selector.select(5.0, planarPose(100.1, 0, 0)).verdict, SelectionVerdict::kRedundant);
}

TEST(KeyframeSelector, ASingleBadFrameDoesNotCountTowardsReanchoring) {
  KeyframeSelectorOptions options;
  options.jump_reanchor_frames = 2;
  KeyframeSelector selector(options);
  selector.select(0.0, planarPose(0, 0, 0));
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(selector.select(2 * i + 1, planarPose(100, 0, 0)).verdict,
              SelectionVerdict::kOdometryJump);
    selector.select(2 * i + 2, planarPose(0.1, 0, 0));  // Back to normal in between.
  }
}

TEST(KeyframeSelectorOptions, ValidateNamesEachProblem) {
  EXPECT_EQ(KeyframeSelectorOptions{}.validate(), "");
  KeyframeSelectorOptions options;
  options.min_motion = 2.0;
  options.max_motion = 1.0;
  options.max_time_gap = -1.0;
  options.translation_weight = 0.0;
  options.rotation_weight = 0.0;
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("advanced/keyframe/max_motion"), std::string::npos) << errors;
  EXPECT_NE(errors.find("advanced/keyframe/max_time_gap"), std::string::npos) << errors;
  EXPECT_NE(errors.find("advanced/keyframe/translation_weight"), std::string::npos) << errors;
}

// KeyframeAdmission (the receiving thread's part of the detector): ids in order, a later map's ids
// only ever raise the next one, and a restart forgets the last keyframe but not the ids.
TEST(KeyframeAdmission, IdsOnlyRiseAndARestartForgetsTheLastKeyframeNotTheIds) {
  KeyframeAdmission admission(InputLimits{}, KeyframeSelectorOptions{});
  constexpr int kWidth = 64, kHeight = 48, kType = 0;  // CV_8UC1.
  FrameAdmission first = admission.admit(1.0, planarPose(0, 0, 0), kWidth, kHeight, kType);
  ASSERT_TRUE(first.isKeyframe());
  EXPECT_EQ(first.keyframe_id, 0u);
  admission.raiseNextId(10);
  admission.raiseNextId(4);  // Lower than the next: ignored.
  FrameAdmission second = admission.admit(2.0, planarPose(1, 0, 0), kWidth, kHeight, kType);
  ASSERT_TRUE(second.isKeyframe());
  EXPECT_EQ(second.keyframe_id, 10u);
  EXPECT_EQ(admission.lastKeyframeStamp(), 2.0);
  // Time went back: refused until restarted; the restart also forgets the image size.
  const FrameAdmission back = admission.admit(1.5, planarPose(2, 0, 0), kWidth, kHeight, kType);
  ASSERT_TRUE(back.error);
  EXPECT_EQ(back.error->code, InputErrorCode::kStampNotIncreasing);
  admission.restart();
  EXPECT_FALSE(admission.lastKeyframeStamp());
  const FrameAdmission after =
      admission.admit(1.5, planarPose(2, 0, 0), 2 * kWidth, kHeight, kType);
  ASSERT_TRUE(after.isKeyframe());
  EXPECT_EQ(after.keyframe_id, 11u);
  const FrameAdmission resized = admission.admit(9.0, planarPose(3, 0, 0), kWidth, kHeight, kType);
  ASSERT_TRUE(resized.error);
  EXPECT_EQ(resized.error->code, InputErrorCode::kImageSizeChanged);
}
