// The shipped encoder through OpenCV's dnn module: it loads, it has CALC's shapes and a standard
// LRN layer, and the descriptors built from it behave.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/descriptors/convnet_descriptor.h"
#include "landmark_loop_closure/sim/corridor_world.h"

using namespace landmark_loop_closure;

namespace {

ConvNetOptions shippedModel() {
  ConvNetOptions options;
  options.model_path = defaultModelPath();
  return options;
}

cv::Mat corridorView(double s, double lateral = 0.0) {
  const sim::CorridorWorld world;
  return world.render(world.poseAt(s, lateral), sim::CameraModel{}, sim::Lighting{}, 1);
}

}  // namespace

TEST(ConvNetDescriptor, ShippedModelLoadsWithStandardLrnAndCalcShapes) {
  cv::dnn::Net net = cv::dnn::readNetFromONNX(defaultModelPath());
  ASSERT_FALSE(net.empty());
  std::vector<cv::String> types;
  net.getLayerTypes(types);
  EXPECT_NE(std::find(types.begin(), types.end(), "LRN"), types.end());

  const ConvNetDescriptor encoder(shippedModel());
  const std::vector<FeatureMaps> maps = encoder.forward(cv::Mat(120, 160, CV_8UC1, cv::Scalar(90)));
  EXPECT_EQ(maps[0].channels, 128);  // conv2: 128 x 32 x 42.
  EXPECT_EQ(maps[0].height, 32);
  EXPECT_EQ(maps[0].width, 42);
  EXPECT_EQ(maps[1].channels, 4);  // conv3: 4 x 14 x 19 = 1064, CALC's descriptor.
  EXPECT_EQ(maps[1].height, 14);
  EXPECT_EQ(maps[1].width, 19);
  EXPECT_EQ(encoder.globalDimension(), 1064);
}

TEST(ConvNetDescriptor, DescribesWithLandmarksInsideTheImage) {
  const ConvNetDescriptor encoder(shippedModel());
  const ImageDescriptor d = encoder.describe(corridorView(5.0));
  ASSERT_EQ(d.global.size(), 1064u);
  EXPECT_NEAR(cv::norm(cv::Mat(d.global)), 1.0, 1e-4);
  ASSERT_FALSE(d.landmark_boxes.empty());
  EXPECT_LE(d.landmark_boxes.size(), 50u);
  EXPECT_EQ(d.landmark_features.rows, static_cast<int>(d.landmark_boxes.size()));
  for (const cv::Rect2f& box : d.landmark_boxes) {
    EXPECT_GE(box.x, 0.0f);
    EXPECT_GE(box.y, 0.0f);
    EXPECT_LE(box.x + box.width, 160.0f + 1e-3f);
    EXPECT_LE(box.y + box.height, 120.0f + 1e-3f);
  }
  // Any input size or colour: the working image is 160x120 grey.
  cv::Mat colour;
  cv::cvtColor(corridorView(5.0), colour, cv::COLOR_GRAY2BGR);
  cv::resize(colour, colour, cv::Size(640, 480));
  EXPECT_EQ(encoder.describe(colour).global.size(), 1064u);
}

TEST(ConvNetDescriptor, SamePlaceScoresHigherThanAnotherPlaceAndScoresAreSymmetric) {
  const ConvNetDescriptor encoder(shippedModel());
  const ImageDescriptor here = encoder.describe(corridorView(20.0));
  const ImageDescriptor here_shifted = encoder.describe(corridorView(20.1, 0.1));
  const ImageDescriptor elsewhere = encoder.describe(corridorView(45.0));
  EXPECT_GT(encoder.similarity(here, here_shifted), encoder.similarity(here, elsewhere));
  EXPECT_DOUBLE_EQ(encoder.similarity(here, elsewhere), encoder.similarity(elsewhere, here));
  EXPECT_GT(cosineSimilarity(here.global, here_shifted.global),
            cosineSimilarity(here.global, elsewhere.global));
}

TEST(ConvNetDescriptor, LandmarksAreHogOfTheirPatchStoredAsFloat16ByDefault) {
  const ConvNetDescriptor encoder(shippedModel());
  DescribeStageTimes times;
  const ImageDescriptor d = encoder.describe(corridorView(5.0), &times);
  ASSERT_FALSE(d.landmark_boxes.empty());
  EXPECT_EQ(d.landmark_features.type(), CV_16F);
  EXPECT_EQ(d.landmark_features.cols, kLandmarkHogDimension);
  EXPECT_GT(times.network, 0.0);
  EXPECT_GE(times.landmark_features, 0.0);
  // Float16 storage halves the landmark bytes and scores like float32.
  ConvNetOptions float32 = shippedModel();
  float32.float16_features = false;
  const ConvNetDescriptor full(float32);
  const ImageDescriptor here = encoder.describe(corridorView(20.0));
  const ImageDescriptor there = encoder.describe(corridorView(20.2, 0.1));
  const ImageDescriptor here32 = full.describe(corridorView(20.0));
  const ImageDescriptor there32 = full.describe(corridorView(20.2, 0.1));
  EXPECT_EQ(here32.landmark_features.size(), here.landmark_features.size());
  EXPECT_EQ(here32.landmark_features.elemSize(), 2 * here.landmark_features.elemSize());
  EXPECT_NEAR(encoder.similarity(here, there), full.similarity(here32, there32), 5e-3);
}

TEST(ConvNetDescriptor, SharedMapCropsAreAvailable) {
  ConvNetOptions options = shippedModel();
  options.features = LandmarkFeatures::kConvMapCrop;
  const ConvNetDescriptor encoder(options);
  const ImageDescriptor d = encoder.describe(corridorView(5.0));
  ASSERT_FALSE(d.landmark_boxes.empty());
  EXPECT_EQ(d.landmark_features.cols, 128 * 2 * 2);  // conv2 channels x grid 2 x 2.
}

TEST(ConvNetDescriptor, PerLandmarkPassDescribesEachCropWithTheWholeNetwork) {
  ConvNetOptions options = shippedModel();
  options.features = LandmarkFeatures::kConvPerLandmark;
  options.proposals.max_landmarks = 5;
  const ConvNetDescriptor encoder(options);
  const ImageDescriptor d = encoder.describe(corridorView(5.0));
  ASSERT_FALSE(d.landmark_boxes.empty());
  EXPECT_EQ(d.landmark_features.cols, 1064);
}

TEST(ConvNetDescriptor, MissingModelOrLayerIsAClearError) {
  ConvNetOptions options;
  options.model_path = "/nonexistent/encoder.onnx";
  try {
    ConvNetDescriptor encoder(options);
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/encoder.onnx"), std::string::npos);
  }
  options = shippedModel();
  options.proposal_layer = "conv9";
  EXPECT_THROW(ConvNetDescriptor encoder(options), std::runtime_error);
}
