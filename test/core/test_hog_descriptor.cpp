#include <cmath>

#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/descriptors/hog_descriptor.h"

using namespace landmark_loop_closure;

namespace {

cv::Mat texturedImage(int seed, int width = 320, int height = 240) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  cv::RNG rng(seed);
  for (int i = 0; i < 40; ++i) {
    cv::rectangle(image,
                  cv::Rect(rng.uniform(0, width - 20), rng.uniform(0, height - 20),
                           rng.uniform(5, 60), rng.uniform(5, 60)),
                  cv::Scalar(rng.uniform(0, 255)), cv::FILLED);
  }
  return image;
}

double norm(const std::vector<float>& v) {
  double sum = 0.0;
  for (float x : v) sum += x * x;
  return std::sqrt(sum);
}

}  // namespace

TEST(HogDescriptor, HasCalcDimensionAndUnitNorm) {
  const HogDescriptor hog;
  const ImageDescriptor descriptor = hog.describe(texturedImage(1));
  ASSERT_EQ(static_cast<int>(descriptor.global.size()), HogDescriptor::kDimension);
  EXPECT_EQ(hog.globalDimension(), 3648);
  EXPECT_NEAR(norm(descriptor.global), 1.0, 1e-5);
  EXPECT_TRUE(descriptor.landmark_boxes.empty());
}

TEST(HogDescriptor, AnyInputSizeAndChannelCountGivesTheSameLength) {
  const HogDescriptor hog;
  cv::Mat colour;
  cv::cvtColor(texturedImage(2, 640, 480), colour, cv::COLOR_GRAY2BGR);
  cv::Mat wide16;
  texturedImage(3, 1280, 300).convertTo(wide16, CV_16U, 256.0);
  EXPECT_EQ(hog.describe(colour).global.size(), 3648u);
  EXPECT_EQ(hog.describe(wide16).global.size(), 3648u);
  EXPECT_EQ(hog.describe(texturedImage(4, 160, 120)).global.size(), 3648u);
}

TEST(HogDescriptor, SimilarImagesScoreHigherThanDifferentOnes) {
  const HogDescriptor hog;
  const cv::Mat base = texturedImage(5);
  cv::Mat brighter;
  base.convertTo(brighter, CV_8U, 0.8, 30.0);
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 4, 0, 1, 2);
  cv::warpAffine(base, shifted, shift, base.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const ImageDescriptor a = hog.describe(base);
  const double same_place_light = hog.similarity(a, hog.describe(brighter));
  const double same_place_shift = hog.similarity(a, hog.describe(shifted));
  const double other_place = hog.similarity(a, hog.describe(texturedImage(6)));
  EXPECT_NEAR(hog.similarity(a, a), 1.0, 1e-5);
  EXPECT_GT(same_place_light, other_place + 0.1);
  EXPECT_GT(same_place_shift, other_place + 0.05);
}

TEST(HogDescriptor, BlankImageGivesZeroVectorNotNaN) {
  const HogDescriptor hog;
  const ImageDescriptor descriptor = hog.describe(cv::Mat(120, 160, CV_8UC1, cv::Scalar(0)));
  for (float v : descriptor.global) ASSERT_TRUE(std::isfinite(v));
  EXPECT_DOUBLE_EQ(hog.similarity(descriptor, descriptor), 0.0);
}

TEST(CosineSimilarity, MismatchedOrEmptyVectorsScoreZero) {
  EXPECT_EQ(cosineSimilarity({}, {}), 0.0);
  EXPECT_EQ(cosineSimilarity({1.0f}, {1.0f, 0.0f}), 0.0);
  EXPECT_NEAR(cosineSimilarity({0.6f, 0.8f}, {0.6f, 0.8f}), 1.0, 1e-6);
}

TEST(DescriptorFactory, DefaultsToTheBackboneKnowsHogAndRefusesUnknownTypes) {
  DescriptorOptions options;
  EXPECT_EQ(options.type, "backbone");
  std::string warning;
  // Without the fetched backbone the package's encoder stands in (fetch_backbone.sh said why).
  EXPECT_EQ(makeDescriptorExtractor(withBackboneFallback(options, &warning))->name(),
            std::filesystem::exists(defaultBackbonePath()) ? "backbone" : "landmarks");
  options.type = "landmarks";
  EXPECT_EQ(makeDescriptorExtractor(options)->name(), "landmarks");
  options.type = "hog";
  EXPECT_EQ(makeDescriptorExtractor(options)->name(), "hog");
  options.type = "sift";
  EXPECT_NE(options.validate(), "");
  EXPECT_THROW(makeDescriptorExtractor(options), std::invalid_argument);
  options = DescriptorOptions();
  EXPECT_EQ(options.validate(), "");
  options.landmark_features = "sift";
  options.landmark_patch = 30;
  options.max_landmark_area = 0.0;
  options.landmark_storage = "int4";
  options.working_width = 8;
  const std::string errors = options.validate();
  for (const char* key : {"landmark_features", "landmark_patch", "max_landmark_area",
                          "landmark_storage", "working_width"}) {
    EXPECT_NE(errors.find(key), std::string::npos) << key;
  }
}
