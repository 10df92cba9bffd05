#include <unistd.h>

#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "identity_backbone.h"
#include "landmark_loop_closure/descriptors/backbone_descriptor.h"
#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "temporary_folder.h"

namespace landmark_loop_closure {
namespace {

class BackboneDescriptorTest : public test::TemporaryFolderTest {
 protected:
  BackboneDescriptorTest() : TemporaryFolderTest("llc_backbone_") {}

  // The grid cells are the mean colours of the image's regions.
  BackboneOptions identityNet() {
    BackboneOptions options = test::identityBackbone(path("identity.onnx"));
    options.grid_rows = 2;
    options.grid_cols = 2;
    options.max_landmarks = 5;
    return options;
  }
};

cv::Mat texturedImage(int seed, cv::Size size = cv::Size(320, 240)) {
  std::mt19937 random(static_cast<unsigned>(seed));
  std::uniform_int_distribution<int> coordinate(0, std::max(size.width, size.height));
  std::uniform_int_distribution<int> shade(0, 255);
  cv::Mat image(size, CV_8UC3, cv::Scalar(60, 90, 120));
  for (int i = 0; i < 40; ++i) {
    cv::rectangle(image, cv::Point(coordinate(random), coordinate(random)),
                  cv::Point(coordinate(random), coordinate(random)),
                  cv::Scalar(shade(random), shade(random), shade(random)), cv::FILLED);
  }
  return image;
}

TEST(NetworkInputBlob, ResizingBeforeTheColourOrderGivesTheSameBlobAsAfter) {
  // The blob is made from the resized image; converting the whole camera frame first (slower)
  // must give the very same values for every input kind and channel order.
  cv::Mat bgr(540, 960, CV_8UC3);
  cv::randu(bgr, 0, 256);
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  const cv::Size size(256, 144);
  const std::vector<double> mean = {0.485, 0.456, 0.406};
  const std::vector<double> deviation = {0.229, 0.224, 0.225};
  const auto reference = [&](const cv::Mat& image, int code) {
    cv::Mat converted;  // Never image's buffer: cvtColor would convert the input in place.
    if (code >= 0) {
      cv::cvtColor(image, converted, code);
    } else {
      converted = image;
    }
    cv::Mat resized;
    cv::resize(converted, resized, size, 0, 0, cv::INTER_AREA);
    return networkInputBlob(resized, size, "bgr", mean, deviation);  // Nothing left to convert.
  };
  const auto same = [](const cv::Mat& a, const cv::Mat& b) {
    return a.size == b.size && cv::norm(a, b, cv::NORM_INF) == 0.0;
  };
  EXPECT_TRUE(
      same(networkInputBlob(bgr, size, "rgb", mean, deviation), reference(bgr, cv::COLOR_BGR2RGB)));
  EXPECT_TRUE(same(networkInputBlob(bgr, size, "bgr", mean, deviation), reference(bgr, -1)));
  EXPECT_TRUE(same(networkInputBlob(bgra, size, "rgb", mean, deviation),
                   reference(bgra, cv::COLOR_BGRA2RGB)));
  EXPECT_TRUE(same(networkInputBlob(grey, size, "rgb", mean, deviation),
                   reference(grey, cv::COLOR_GRAY2BGR)));
  const cv::Mat grey_blob = networkInputBlob(bgr, size, "grey", {0.5}, {0.25});
  cv::Mat grey_resized;
  cv::resize(grey, grey_resized, size, 0, 0, cv::INTER_AREA);
  EXPECT_TRUE(same(grey_blob, networkInputBlob(grey_resized, size, "grey", {0.5}, {0.25})))
      << "grey from colour is taken before resizing, as before";
}

TEST(NetworkInputBlob, PixelsTakenAsTheyAreMakeTheBlobOfOpenCVsPasses) {
  // Mean 0 and deviation 1 (the shipped network): the blob is written in one pass, and must hold
  // the very floats OpenCV's conversion, channel swap and blob layout give.
  cv::Mat bgr(540, 960, CV_8UC3);
  cv::randu(bgr, 0, 256);
  const cv::Size size(256, 144);
  for (const std::string colour : {"rgb", "bgr"}) {
    cv::Mat resized;
    cv::resize(bgr, resized, size, 0, 0, cv::INTER_AREA);
    cv::Mat ordered;
    if (colour == "rgb") {
      cv::cvtColor(resized, ordered, cv::COLOR_BGR2RGB);
    } else {
      ordered = resized;
    }
    cv::Mat scaled;
    ordered.convertTo(scaled, CV_32F, 1.0 / 255.0);
    const cv::Mat expected = cv::dnn::blobFromImage(scaled);
    const cv::Mat blob = networkInputBlob(bgr, size, colour, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0});
    ASSERT_EQ(blob.size, expected.size) << colour;
    EXPECT_EQ(cv::norm(blob, expected, cv::NORM_INF), 0.0) << colour;
    const int first_plane_pixel[] = {0, 0, 7, 9};
    EXPECT_EQ(blob.at<float>(first_plane_pixel),
              ordered.at<cv::Vec3b>(7, 9)[0] * static_cast<float>(1.0 / 255.0))
        << colour << ": the first plane is the first channel of the network's order";
  }
}

TEST(GridPool, AveragesEachCellOfEveryChannel) {
  FeatureMaps maps;
  maps.channels = 2;
  maps.height = 4;
  maps.width = 4;
  for (int c = 0; c < 2; ++c) {
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 4; ++x) maps.values.push_back(c == 0 ? float(x) : float(10 * y));
    }
  }
  const std::vector<float> pooled = gridPool(maps, 2, 2);
  ASSERT_EQ(pooled.size(), 8u);  // cells (0,0) (0,1) (1,0) (1,1), two channels each
  EXPECT_FLOAT_EQ(pooled[0], 0.5f);
  EXPECT_FLOAT_EQ(pooled[1], 5.0f);
  EXPECT_FLOAT_EQ(pooled[2], 2.5f);
  EXPECT_FLOAT_EQ(pooled[3], 5.0f);
  EXPECT_FLOAT_EQ(pooled[4], 0.5f);
  EXPECT_FLOAT_EQ(pooled[5], 25.0f);
  EXPECT_FLOAT_EQ(pooled[7], 25.0f);
}

// Signed GeM: p = 2 over {3, -4} is sign(m) sqrt(|m|) with m = (9 - 16) / 2; large p tends to
// the value of largest magnitude, with its sign; p = 1 is the mean.
TEST(GridPool, GeneralisedMeanKeepsTheSignAndTendsToTheStrongestValue) {
  FeatureMaps maps;
  maps.channels = 2;
  maps.height = 1;
  maps.width = 2;
  maps.values = {3.0f, -4.0f, 1.0f, 2.0f};  // channel 0: 3, -4; channel 1: 1, 2
  const std::vector<float> mean = gridPool(maps, 1, 1, 1.0);
  EXPECT_FLOAT_EQ(mean[0], -0.5f);
  EXPECT_FLOAT_EQ(mean[1], 1.5f);
  const std::vector<float> gem2 = gridPool(maps, 1, 1, 2.0);
  EXPECT_NEAR(gem2[0], -std::sqrt(3.5), 1e-5);
  EXPECT_NEAR(gem2[1], std::sqrt(2.5), 1e-5);
  const std::vector<float> gem16 = gridPool(maps, 1, 1, 16.0);
  EXPECT_NEAR(gem16[0], -4.0 * std::pow(0.5 * (1.0 - std::pow(0.75, 16)), 1.0 / 16), 1e-4);
  EXPECT_GT(gem16[1], 1.8f);
  EXPECT_LT(gem16[1], 2.0f);
}

TEST(GridPool, MoreCellsThanTheMapHasStillGivesEveryCellAValue) {
  FeatureMaps maps;
  maps.channels = 1;
  maps.height = 2;
  maps.width = 2;
  maps.values = {1, 2, 3, 4};
  const std::vector<float> pooled = gridPool(maps, 3, 4);
  ASSERT_EQ(pooled.size(), 12u);
  for (const float value : pooled) EXPECT_GE(value, 1.0f);
}

TEST_F(BackboneDescriptorTest, GridOfMeanColoursInTheNetworksChannelOrder) {
  BackboneOptions options = identityNet();
  options.max_landmarks = 0;
  const BackboneDescriptor descriptor(options);
  EXPECT_EQ(descriptor.globalDimension(), 2 * 2 * 3);
  EXPECT_TRUE(descriptor.wantsColour());
  cv::Mat image(24, 32, CV_8UC3, cv::Scalar(0, 0, 0));
  image(cv::Rect(0, 0, 16, 12)).setTo(cv::Scalar(0, 0, 255));  // top-left red (BGR)
  const ImageDescriptor described = descriptor.describe(image);
  ASSERT_EQ(described.global.size(), 12u);
  // Each cell is L2-normalised, then the whole: the red cell is (1, 0, 0) in RGB order, black
  // cells are zero.
  EXPECT_NEAR(described.global[0], 1.0, 1e-5);
  EXPECT_NEAR(described.global[1], 0.0, 1e-5);
  for (size_t i = 3; i < 12; ++i) EXPECT_NEAR(described.global[i], 0.0, 1e-5);
}

TEST_F(BackboneDescriptorTest, SameSceneInOtherLightScoresAboveAnotherScene) {
  BackboneOptions options = identityNet();
  options.grid_rows = 3;
  options.grid_cols = 4;
  const BackboneDescriptor descriptor(options);
  const cv::Mat place = texturedImage(1);
  cv::Mat darker;
  place.convertTo(darker, -1, 0.4, 0.0);
  const cv::Mat other = texturedImage(2);
  const ImageDescriptor a = descriptor.describe(place);
  EXPECT_NEAR(descriptor.similarity(a, descriptor.describe(place)), 1.0, 1e-5);
  EXPECT_GT(descriptor.similarity(a, descriptor.describe(darker)),
            descriptor.similarity(a, descriptor.describe(other)));
}

TEST_F(BackboneDescriptorTest, LandmarksComeFromTheActivationsInTheThumbnailFrame) {
  BackboneOptions options = identityNet();
  const BackboneDescriptor descriptor(options);
  cv::Mat image(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::rectangle(image, cv::Rect(40, 60, 80, 60), cv::Scalar(255, 255, 255), cv::FILLED);
  const ImageDescriptor described = descriptor.describe(image);
  ASSERT_FALSE(described.landmark_boxes.empty());
  EXPECT_EQ(described.landmark_features.rows, static_cast<int>(described.landmark_boxes.size()));
  EXPECT_EQ(described.landmark_features.type(), CV_16F);  // float16 by default
  // The bright block sits at (20, 30)-(60, 60) of the 160x120 frame.
  const cv::Rect2f& box = described.landmark_boxes.front();
  EXPECT_NEAR(box.x, 20.0, 5.0);
  EXPECT_NEAR(box.y, 30.0, 5.0);
  EXPECT_NEAR(box.x + box.width, 60.0, 5.0);
  EXPECT_NEAR(box.y + box.height, 60.0, 5.0);
}

TEST_F(BackboneDescriptorTest, ReRankingBlendsTheLandmarkScoreIn) {
  BackboneOptions options = identityNet();
  const BackboneDescriptor plain(options);
  EXPECT_FALSE(plain.reranks());
  options.rerank_weight = 0.5;
  const BackboneDescriptor blended(options);
  EXPECT_TRUE(blended.reranks());
  const ImageDescriptor a = blended.describe(texturedImage(3));
  const ImageDescriptor b = blended.describe(texturedImage(4));
  const double landmarks =
      landmarkSimilarity(a.landmark_boxes, a.landmark_features, b.landmark_boxes,
                         b.landmark_features, ShapeWeighting::kPenalise);
  EXPECT_NEAR(blended.similarity(a, b),
              0.5 * cosineSimilarity(a.global, b.global) + 0.5 * landmarks, 1e-9);
}

TEST_F(BackboneDescriptorTest, SmallImagesAreDescribedByHogAloneAndWideOnesFuseIt) {
  BackboneOptions options = identityNet();
  options.hog_weight = 0.25;
  options.min_network_width = 100;
  const BackboneDescriptor descriptor(options);
  const int grid_dimension = 2 * 2 * 3;
  ASSERT_GT(descriptor.globalDimension(), grid_dimension);

  const auto share = [&](const ImageDescriptor& d) {  // squared norm of the network's part
    double sum = 0.0;
    for (int i = 0; i < grid_dimension; ++i) sum += d.global[i] * d.global[i];
    return sum;
  };
  const ImageDescriptor small = descriptor.describe(texturedImage(5, cv::Size(64, 32)));
  EXPECT_NEAR(share(small), 0.0, 1e-9);
  EXPECT_TRUE(small.landmark_boxes.empty());
  const ImageDescriptor wide = descriptor.describe(texturedImage(5));
  EXPECT_NEAR(share(wide), 0.75, 1e-4);
  double norm = 0.0;
  for (const float v : wide.global) norm += v * v;
  EXPECT_NEAR(norm, 1.0, 1e-4);
  // What the node logs at its first image says which path and why.
  const std::string small_path = descriptor.describesAs(cv::Size(64, 32));
  EXPECT_NE(small_path.find("HOG alone"), std::string::npos) << small_path;
  EXPECT_NE(small_path.find("min_network_width (100 px)"), std::string::npos) << small_path;
  const std::string wide_path = descriptor.describesAs(cv::Size(320, 240));
  EXPECT_NE(wide_path.find("go through the network"), std::string::npos) << wide_path;
  EXPECT_NE(wide_path.find("HOG at weight 0.25"), std::string::npos) << wide_path;
}

TEST_F(BackboneDescriptorTest, ImagesItCannotReadGiveAnEmptyDescriptor) {
  const BackboneDescriptor descriptor(identityNet());
  EXPECT_TRUE(descriptor.describe(cv::Mat()).empty());
  EXPECT_TRUE(descriptor.describe(cv::Mat(24, 32, CV_16UC1, cv::Scalar(1000))).empty());
  // Grey and BGRA are converted.
  EXPECT_FALSE(descriptor.describe(cv::Mat(24, 32, CV_8UC1, cv::Scalar(90))).empty());
  EXPECT_FALSE(descriptor.describe(cv::Mat(24, 32, CV_8UC4, cv::Scalar(9, 90, 200, 255))).empty());
}

TEST_F(BackboneDescriptorTest, AMissingModelOrLayerIsNamed) {
  BackboneOptions options = identityNet();
  options.model_path = path("absent.onnx");
  try {
    BackboneDescriptor descriptor(options);
    FAIL() << "a missing model was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("absent.onnx"), std::string::npos) << error.what();
  }
  options = identityNet();
  options.layer = "no_such_layer";
  try {
    BackboneDescriptor descriptor(options);
    FAIL() << "a missing layer was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("no_such_layer"), std::string::npos) << error.what();
  }
}

TEST_F(BackboneDescriptorTest, ANetworkThatIsNotMobileNetV2StaysWithOpenCvAndSaysWhy) {
  const BackboneOptions options = identityNet();
  cv::dnn::Net net = cv::dnn::readNetFromONNX(options.model_path);
  std::string why;
  EXPECT_EQ(OneDnnMobileNet::create(net, options.input_size, {"features"}, &why), nullptr);
  EXPECT_FALSE(why.empty());
  const BackboneDescriptor descriptor(options);
  EXPECT_NE(descriptor.describesAs(cv::Size(320, 240)).find("on OpenCV's dnn"), std::string::npos)
      << descriptor.describesAs(cv::Size(320, 240));
}

// The package's backbone, where scripts/fetch_backbone.sh has fetched it.
std::string packageBackbone() {
  const std::string model = backboneModelPath(DescriptorOptions::Backbone());
  return std::filesystem::exists(model) ? model : "";
}

TEST(OneDnnMobileNet, GivesOpenCvsOutputsForThePackagesBackbone) {
  const std::string model = packageBackbone();
  if (model.empty()) GTEST_SKIP() << "the backbone was not fetched";
  if (!OneDnnMobileNet::available()) GTEST_SKIP() << "built without oneDNN";
  const cv::Size input(256, 144);
  cv::dnn::Net net = cv::dnn::readNetFromONNX(model);
  std::string why;
  std::unique_ptr<OneDnnMobileNet> fast =
      OneDnnMobileNet::create(net, input, {"block_12_add", "block_5_add"}, &why);
  ASSERT_NE(fast, nullptr) << why;
  // Another input than create()'s own check, against a network OpenCV alone has run.
  cv::dnn::Net reference = cv::dnn::readNetFromONNX(model);
  const int shape[] = {1, 3, input.height, input.width};
  cv::Mat blob(4, shape, CV_32F);
  cv::randu(blob, -1.0, 2.0);
  std::vector<cv::Mat> expected;
  reference.setInput(blob);
  reference.forward(expected, std::vector<cv::String>{"block_12_add", "block_5_add"});
  const std::vector<cv::Mat> got = fast->forward(blob);
  ASSERT_EQ(got.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    ASSERT_EQ(got[k].size, expected[k].size) << k;
    const double largest = cv::norm(expected[k], cv::NORM_INF);
    EXPECT_LE(cv::norm(got[k].reshape(1, 1), expected[k].reshape(1, 1), cv::NORM_INF),
              1e-4 * largest)
        << k;
  }
  // An output the network does not have is refused by name, not guessed.
  EXPECT_EQ(OneDnnMobileNet::create(net, input, {"block_99_add"}, &why), nullptr);
  EXPECT_FALSE(why.empty());
  // The wrong input size is refused.
  EXPECT_THROW(fast->forward(cv::Mat(4, std::vector<int>{1, 3, 10, 10}.data(), CV_32F)),
               std::invalid_argument);
}

TEST(OneDnnMobileNet, TheDescriptorIsTheSameOnEitherEngine) {
  const std::string model = packageBackbone();
  if (model.empty()) GTEST_SKIP() << "the backbone was not fetched";
  BackboneOptions options;
  options.model_path = model;
  const BackboneDescriptor automatic(options);
  options.engine = "opencv";
  const BackboneDescriptor opencv(options);
  EXPECT_NE(opencv.describesAs(cv::Size(640, 480)).find("engine opencv"), std::string::npos);
  if (OneDnnMobileNet::available()) {
    EXPECT_NE(automatic.describesAs(cv::Size(640, 480)).find("on oneDNN"), std::string::npos);
  }
  for (int seed = 0; seed < 3; ++seed) {
    const cv::Mat image = texturedImage(seed, cv::Size(640, 480));
    const ImageDescriptor a = automatic.describe(image);
    const ImageDescriptor b = opencv.describe(image);
    EXPECT_GT(cosineSimilarity(a.global, b.global), 0.99999) << seed;
    EXPECT_EQ(a.landmark_boxes.size(), b.landmark_boxes.size()) << seed;
  }
}

TEST(BackboneOptions, ValidateNamesEveryBadValue) {
  DescriptorOptions options;
  options.type = "backbone";
  EXPECT_EQ(options.validate(), "");
  options.backbone.grid_rows = 0;
  options.backbone.hog_weight = 1.5;
  options.backbone.mean = "0 0";
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("advanced/descriptor/backbone/grid_rows"), std::string::npos) << errors;
  EXPECT_NE(errors.find("advanced/descriptor/backbone/hog_weight"), std::string::npos) << errors;
  EXPECT_NE(errors.find("mobilenet_v2.onnx.json: mean"), std::string::npos) << errors;
}

TEST(BackboneOptions, FallsBackToThePackagesEncoderOnlyWhenTheBackboneWasNeverFetched) {
  DescriptorOptions options;
  options.type = "backbone";
  std::string warning;
  const DescriptorOptions used = withBackboneFallback(options, &warning);
  if (std::filesystem::exists(defaultBackbonePath())) {
    EXPECT_EQ(used.type, "backbone");
    EXPECT_TRUE(warning.empty());
  } else {
    EXPECT_EQ(used.type, "landmarks");
    EXPECT_NE(warning.find("fetch_backbone.sh"), std::string::npos) << warning;
  }
  options.backbone.model = "/somewhere/own.onnx";  // a user's own network is never replaced
  EXPECT_EQ(withBackboneFallback(options, &warning).type, "backbone");
  EXPECT_TRUE(warning.empty());
  options.type = "hog";
  EXPECT_EQ(withBackboneFallback(options, &warning).type, "hog");
}

}  // namespace
}  // namespace landmark_loop_closure
