#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "onnx_test_model.h"
#include "temporary_folder.h"

namespace landmark_loop_closure {
namespace {

class CnnGlobalDescriptorTest : public test::TemporaryFolderTest {
 protected:
  CnnGlobalDescriptorTest() : TemporaryFolderTest("llc_cnn_") {}

  // Three colour channels in, three out: output k = input channel k (identity 1x1 convolution).
  CnnGlobalOptions colourNet(const std::string& layer, FeaturePooling pooling) {
    const std::string model = path("colour.onnx");
    test::writeOneByOneConvNet(model, 3, 8, 8, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0});
    CnnGlobalOptions options;
    options.model_path = model;
    options.layer = layer;
    options.input_size = cv::Size(8, 8);
    options.mean = {0, 0, 0};
    options.std = {1, 1, 1};
    options.pooling = pooling;
    return options;
  }
};

Eigen::Vector3f unit(float a, float b, float c) { return Eigen::Vector3f(a, b, c).normalized(); }

TEST_F(CnnGlobalDescriptorTest, ReadsTheLayerInTheNetworksColourOrder) {
  CnnGlobalOptions options = colourNet("pooled", FeaturePooling::kAverage);
  const cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(10, 100, 200));  // B, G, R.

  options.colour = "rgb";
  const CnnGlobalDescriptor rgb(options);
  EXPECT_EQ(rgb.rawDimension(), 3);
  EXPECT_TRUE(rgb.rawFeature(bgr).isApprox(unit(200, 100, 10), 1e-5f));

  EXPECT_TRUE(rgb.wantsColour());  // The node then hands it BGR images, not grey.

  options.colour = "bgr";
  const CnnGlobalDescriptor bgr_net(options);
  EXPECT_TRUE(bgr_net.rawFeature(bgr).isApprox(unit(10, 100, 200), 1e-5f));

  // A grey camera: every channel gets the grey value.
  const cv::Mat grey(8, 8, CV_8UC1, cv::Scalar(90));
  EXPECT_TRUE(rgb.rawFeature(grey).isApprox(unit(1, 1, 1), 1e-5f));
  // Resized to the network's input first: a larger uniform image gives the same vector.
  const cv::Mat large(480, 640, CV_8UC3, cv::Scalar(10, 100, 200));
  EXPECT_TRUE(rgb.rawFeature(large).isApprox(unit(200, 100, 10), 1e-5f));
}

TEST_F(CnnGlobalDescriptorTest, PoolsFeatureMapsAsAsked) {
  // Left half red, right half blue (BGR order in OpenCV).
  cv::Mat image(8, 8, CV_8UC3, cv::Scalar(0, 0, 200));
  image(cv::Rect(4, 0, 4, 8)).setTo(cv::Scalar(100, 0, 0));
  CnnGlobalOptions options = colourNet("features", FeaturePooling::kAverage);
  EXPECT_TRUE(CnnGlobalDescriptor(options).rawFeature(image).isApprox(unit(100, 0, 50), 1e-5f));
  options.pooling = FeaturePooling::kMax;
  EXPECT_TRUE(CnnGlobalDescriptor(options).rawFeature(image).isApprox(unit(200, 0, 100), 1e-5f));
  options.pooling = FeaturePooling::kNone;
  const CnnGlobalDescriptor flat(options);
  EXPECT_EQ(flat.rawDimension(), 3 * 8 * 8);
  const Eigen::VectorXf values = flat.rawFeature(image);
  // Channel 0 (red) holds the left half, channel 2 (blue) the right half.
  EXPECT_GT(values(0), 0.0f);
  EXPECT_EQ(values(7), 0.0f);
  EXPECT_EQ(values(2 * 64 + 0), 0.0f);
  EXPECT_GT(values(2 * 64 + 7), 0.0f);
}

TEST_F(CnnGlobalDescriptorTest, AppliesMeanAndStd) {
  // One grey channel in; out: relu(x) and relu(1 - x), with x = (pixel / 255 - 0.5) / 0.25.
  const std::string model = path("grey.onnx");
  test::writeOneByOneConvNet(model, 1, 8, 8, {1, -1}, {0, 1});
  CnnGlobalOptions options;
  options.model_path = model;
  options.layer = "pooled";
  options.input_size = cv::Size(8, 8);
  options.colour = "grey";
  options.mean = {0.5};
  options.std = {0.25};
  const CnnGlobalDescriptor net(options);
  EXPECT_FALSE(net.wantsColour());
  const auto feature = [&net](int pixel) {
    return net.rawFeature(cv::Mat(8, 8, CV_8UC1, cv::Scalar(pixel)));
  };
  EXPECT_TRUE(feature(153).isApprox(Eigen::Vector2f(0.4f, 0.6f).normalized(), 1e-4f));  // x = 0.4
  EXPECT_TRUE(feature(255).isApprox(Eigen::Vector2f(1, 0), 1e-5f));                     // x = 2
  EXPECT_TRUE(feature(0).isApprox(Eigen::Vector2f(0, 1), 1e-5f));                       // x = -2
  // A colour image for a grey network is converted to grey.
  EXPECT_TRUE(net.rawFeature(cv::Mat(8, 8, CV_8UC3, cv::Scalar(255, 255, 255)))
                  .isApprox(Eigen::Vector2f(1, 0), 1e-5f));
}

TEST_F(CnnGlobalDescriptorTest, WhiteningFromAFileShapesTheDescriptor) {
  CnnGlobalOptions options = colourNet("features", FeaturePooling::kNone);
  options.colour = "bgr";
  const CnnGlobalDescriptor raw(options);
  std::mt19937 random(3);
  std::uniform_int_distribution<int> level(0, 255);
  const auto randomImage = [&]() {
    cv::Mat image(8, 8, CV_8UC3);
    for (int i = 0; i < 8 * 8 * 3; ++i) image.data[i] = static_cast<uchar>(level(random));
    return image;
  };
  Eigen::MatrixXf samples(60, raw.rawDimension());
  for (int i = 0; i < samples.rows(); ++i)
    samples.row(i) = raw.rawFeature(randomImage()).transpose();
  const PcaWhitening fitted = PcaWhitening::fit(samples, 16, 1e-3);
  fitted.save(path("net.whitening"), raw.featureIdentity());

  options.whitening_path = path("net.whitening");
  const CnnGlobalDescriptor whitened(options);
  EXPECT_EQ(whitened.globalDimension(), 16);
  const cv::Mat image = randomImage();
  const ImageDescriptor descriptor = whitened.describe(image);
  ASSERT_EQ(descriptor.global.size(), 16u);
  const Eigen::Map<const Eigen::VectorXf> global(descriptor.global.data(), 16);
  EXPECT_NEAR(global.norm(), 1.0f, 1e-5f);
  EXPECT_TRUE(global.isApprox(fitted.apply(raw.rawFeature(image)).normalized(), 1e-4f));

  // A whitening fitted on another layer's features is refused, naming the file.
  options.layer = "pooled";
  options.pooling = FeaturePooling::kAverage;
  try {
    CnnGlobalDescriptor wrong(options);
    FAIL() << "a whitening for other features was accepted";
  } catch (const WhiteningFileError& error) {
    EXPECT_NE(std::string(error.what()).find("net.whitening"), std::string::npos);
  }
}

TEST_F(CnnGlobalDescriptorTest, DistanceSimilarityRanksAsCosine) {
  CnnGlobalOptions options = colourNet("pooled", FeaturePooling::kAverage);
  const CnnGlobalDescriptor distance(options);
  options.similarity = GlobalSimilarity::kCosine;
  const CnnGlobalDescriptor cosine(options);
  EXPECT_DOUBLE_EQ(distance.globalScore(1.0), 1.0);   // D = 0
  EXPECT_DOUBLE_EQ(distance.globalScore(-1.0), 0.0);  // D = 2, the largest possible
  EXPECT_NEAR(distance.globalScore(0.0), 1.0 - std::sqrt(2.0) / 2.0, 1e-12);
  EXPECT_LT(distance.globalScore(0.5), distance.globalScore(0.6));
  EXPECT_DOUBLE_EQ(cosine.globalScore(0.3), 0.3);

  const ImageDescriptor a = distance.describe(cv::Mat(8, 8, CV_8UC3, cv::Scalar(10, 100, 200)));
  const ImageDescriptor b = distance.describe(cv::Mat(8, 8, CV_8UC3, cv::Scalar(200, 100, 10)));
  const double d = (Eigen::Map<const Eigen::Vector3f>(a.global.data()) -
                    Eigen::Map<const Eigen::Vector3f>(b.global.data()))
                       .norm();
  EXPECT_NEAR(distance.similarity(a, b), 1.0 - d / 2.0, 1e-6);
}

TEST_F(CnnGlobalDescriptorTest, RefusesMissingModelsLayersAndBadSettings) {
  CnnGlobalOptions options = colourNet("pooled", FeaturePooling::kAverage);
  options.model_path = path("missing.onnx");
  try {
    CnnGlobalDescriptor missing(options);
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("missing.onnx"), std::string::npos);
  }
  options = colourNet("no_such_layer", FeaturePooling::kAverage);
  try {
    CnnGlobalDescriptor no_layer(options);
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("no_such_layer"), std::string::npos);
  }
  options = colourNet("pooled", FeaturePooling::kAverage);
  options.mean = {0.5};  // Three channels need three means.
  EXPECT_THROW(CnnGlobalDescriptor{options}, std::runtime_error);
  options = colourNet("pooled", FeaturePooling::kAverage);
  options.std = {1, 0, 1};
  EXPECT_THROW(CnnGlobalDescriptor{options}, std::runtime_error);

  const CnnGlobalDescriptor good(colourNet("pooled", FeaturePooling::kAverage));
  EXPECT_TRUE(good.describe(cv::Mat()).empty());
  EXPECT_TRUE(good.describe(cv::Mat(8, 8, CV_32FC1, cv::Scalar(0.5))).empty());
}

// The package's own encoder as the CNN: its conv3 maps, flattened.
TEST(CnnGlobalDescriptorPackageModel, DescribesWithThePackagesEncoder) {
  DescriptorOptions options;
  options.type = "cnn_pca";
  options.cnn.whitening = "none";
  ASSERT_EQ(options.validate(), "");
  const auto extractor = makeDescriptorExtractor(options);
  EXPECT_EQ(extractor->name(), "cnn_pca");
  EXPECT_EQ(extractor->globalDimension(), 1064);

  // A textured scene, the same scene shifted by a few pixels, and another scene.
  const auto scene = [](int seed) {
    cv::Mat image(240, 320, CV_8UC1, cv::Scalar(90));
    std::mt19937 local(seed);
    std::uniform_int_distribution<int> x(0, 300), y(0, 220), size(8, 50), level(0, 255);
    for (int i = 0; i < 60; ++i) {
      cv::rectangle(image, cv::Rect(x(local), y(local), size(local), size(local)),
                    cv::Scalar(level(local)), cv::FILLED);
    }
    return image;
  };
  const cv::Mat place = scene(1);
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 4, 0, 1, 3);
  cv::warpAffine(place, shifted, shift, place.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const ImageDescriptor a = extractor->describe(place);
  const ImageDescriptor b = extractor->describe(shifted);
  const ImageDescriptor c = extractor->describe(scene(2));
  EXPECT_GT(extractor->similarity(a, b), extractor->similarity(a, c));

  DescriptorOptions bad = options;
  bad.cnn.colour = "rgb";  // Three channels, but mean and std give one value.
  EXPECT_NE(bad.validate().find(".onnx.json: mean"), std::string::npos);
  bad = options;
  bad.cnn.pooling = "median";
  EXPECT_NE(bad.validate().find("advanced/descriptor/cnn/pooling"), std::string::npos);
  // Identity changes with the whitening and the layer, so databases are not mixed.
  DescriptorOptions other = options;
  other.cnn.layer = "conv2";
  EXPECT_NE(descriptorIdentity(options), descriptorIdentity(other));
}

}  // namespace
}  // namespace landmark_loop_closure
