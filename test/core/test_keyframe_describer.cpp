// The description stage: standardised vectors, and the keyframes held while the window fills
// described again by the full window.
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/core/keyframe_describer.h"
#include "place_extractor.h"

namespace landmark_loop_closure {
namespace {

using test_support::place;
using test_support::PlaceExtractor;

DescriptorOptions withWindow(int window) {
  DescriptorOptions options;
  options.condition_window = window;
  return options;
}

double cosine(const std::vector<float>& a, const std::vector<float>& b) {
  double dot = 0.0, na = 0.0, nb = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    dot += double(a[i]) * b[i];
    na += double(a[i]) * a[i];
    nb += double(b[i]) * b[i];
  }
  return dot / std::sqrt(na * nb);
}

TEST(KeyframeDescriber, IdentityNamesTheExtractorAndNothingWithoutOne) {
  const KeyframeDescriber describer(std::make_shared<PlaceExtractor>(), withWindow(4));
  EXPECT_TRUE(describer.hasExtractor());
  EXPECT_EQ(describer.identity().rfind("extractor=place ", 0), 0u) << describer.identity();
  const KeyframeDescriber none(nullptr, withWindow(4));
  EXPECT_FALSE(none.hasExtractor());
  EXPECT_TRUE(none.identity().empty());
}

TEST(KeyframeDescriber, WithoutAWindowNothingIsHeldAndVectorsPassUnchanged) {
  KeyframeDescriber describer(std::make_shared<PlaceExtractor>(), withWindow(0));
  std::vector<float> raw;
  const ImageDescriptor descriptor = describer.describe(place(7), &raw);
  EXPECT_FALSE(describer.warmingUp());
  EXPECT_EQ(descriptor.global, raw);
  EXPECT_FLOAT_EQ(descriptor.global[7], 1.0f);
  EXPECT_TRUE(describer.takeHeld().empty());
}

TEST(KeyframeDescriber, HeldKeyframesAreDescribedByTheFullWindowOnceItFills) {
  constexpr int kWindow = 4;
  KeyframeDescriber describer(std::make_shared<PlaceExtractor>(), withWindow(kWindow));
  ConditionStandardiser reference(kWindow);
  std::vector<std::vector<float>> raws;
  for (int i = 0; i < kWindow; ++i) {
    EXPECT_TRUE(describer.warmingUp() || i == 0) << i;
    std::vector<float> raw;
    const ImageDescriptor descriptor = describer.describe(place(10 + i), &raw);
    EXPECT_EQ(descriptor.global, reference.apply(raw)) << "keyframe " << i;
    raws.push_back(raw);
    if (i + 1 < kWindow) {
      ASSERT_TRUE(describer.warmingUp()) << i;
      KeyframeRecord keyframe;
      keyframe.id = static_cast<uint64_t>(i + 1);
      keyframe.descriptor = descriptor;
      describer.hold(std::move(keyframe), raw);
    }
  }
  ASSERT_FALSE(describer.warmingUp());
  ASSERT_TRUE(describer.holding());
  const std::vector<KeyframeRecord> held = describer.takeHeld();
  EXPECT_FALSE(describer.holding());
  ASSERT_EQ(held.size(), static_cast<size_t>(kWindow - 1));
  for (size_t i = 0; i < held.size(); ++i) {
    EXPECT_EQ(held[i].id, i + 1) << "oldest first";
    EXPECT_EQ(held[i].descriptor.global, reference.standardise(raws[i])) << i;
  }
  // The first keyframe alone in its window was all zeros; the full window tells it apart.
  EXPECT_GT(cosine(held[0].descriptor.global, describer.describe(place(10)).global), 0.5);
}

TEST(KeyframeDescriber, KeyframesTakenBeforeTheWindowFillsKeepTheirDescriptors) {
  KeyframeDescriber describer(std::make_shared<PlaceExtractor>(), withWindow(8));
  const ImageDescriptor first = describer.describe(place(3));
  const ImageDescriptor second = describer.describe(place(4));
  KeyframeRecord keyframe;
  keyframe.id = 2;
  keyframe.descriptor = second;
  describer.hold(keyframe, {});
  ASSERT_TRUE(describer.warmingUp());
  const std::vector<KeyframeRecord> held = describer.takeHeld();  // A save came first.
  ASSERT_EQ(held.size(), 1u);
  EXPECT_EQ(held[0].descriptor.global, second.global);
  EXPECT_TRUE(describer.previousGlobal().empty());
  describer.setPreviousGlobal(first.global);
  EXPECT_EQ(describer.previousGlobal(), first.global);
}

}  // namespace
}  // namespace landmark_loop_closure
