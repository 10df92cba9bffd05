#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "file_bytes.h"
#include "identity_backbone.h"
#include "landmark_loop_closure/descriptors/backbone_descriptor.h"
#include "landmark_loop_closure/descriptors/vlad.h"
#include "temporary_folder.h"

namespace landmark_loop_closure {
namespace {

class VladTest : public test::TemporaryFolderTest {
 protected:
  VladTest() : TemporaryFolderTest("llc_vlad_") {}
};

cv::Mat rows(std::initializer_list<std::initializer_list<float>> values) {
  cv::Mat matrix;
  for (const auto& row : values) matrix.push_back(cv::Mat(std::vector<float>(row)).t());
  return matrix;
}

// Three tight blobs around known centres in 4 dimensions.
cv::Mat threeBlobs(int per_blob, unsigned seed) {
  const cv::Mat centres = rows({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}});
  std::mt19937 random(seed);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  cv::Mat samples(3 * per_blob, 4, CV_32F);
  for (int i = 0; i < samples.rows; ++i) {
    for (int d = 0; d < 4; ++d)
      samples.at<float>(i, d) = centres.at<float>(i % 3, d) + noise(random);
  }
  return samples;
}

TEST(Vlad, HardAssignmentSumsResidualsPerCentreThenNormalises) {
  const VladVocabulary vocabulary(rows({{1, 0}, {0, 1}}), "test");
  // Two features near the first centre, one near the second.
  const cv::Mat features = rows({{1, 0.5f}, {1, 0.25f}, {0.2f, 1}});
  const std::vector<float> vlad = vladAggregate(features, vocabulary);
  ASSERT_EQ(vlad.size(), 4u);
  // Residual sums: centre 0 (0, 0.75), centre 1 (0.2, 0): signed square roots, each centre
  // normalised, then the whole: (0, 1) and (1, 0) over sqrt(2).
  const float half = static_cast<float>(1.0 / std::sqrt(2.0));
  EXPECT_NEAR(vlad[0], 0.0f, 1e-6f);
  EXPECT_NEAR(vlad[1], half, 1e-6f);
  EXPECT_NEAR(vlad[2], half, 1e-6f);
  EXPECT_NEAR(vlad[3], 0.0f, 1e-6f);
}

TEST(Vlad, PowerLawKeepsTheResidualsSign) {
  const VladVocabulary vocabulary(rows({{0, 0}}), "test");
  const std::vector<float> vlad = vladAggregate(rows({{-4, 1}}), vocabulary);
  // (-4, 1) -> (-2, 1) -> normalised.
  EXPECT_NEAR(vlad[0], -2.0f / std::sqrt(5.0f), 1e-6f);
  EXPECT_NEAR(vlad[1], 1.0f / std::sqrt(5.0f), 1e-6f);
}

TEST(Vlad, SoftAssignmentSplitsAFeatureBetweenEquallyNearCentres) {
  const VladVocabulary vocabulary(rows({{1, 0}, {0, 1}, {-5, -5}}), "test");
  VladOptions soft;
  soft.assignments = 2;
  const std::vector<float> vlad = vladAggregate(rows({{1, 1}}), vocabulary, soft);
  // Residual (0, 1) to centre 0 and (1, 0) to centre 1, half each; the far centre gets nothing.
  const float half = static_cast<float>(1.0 / std::sqrt(2.0));
  EXPECT_NEAR(vlad[1], half, 1e-6f);
  EXPECT_NEAR(vlad[2], half, 1e-6f);
  EXPECT_EQ(vlad[4], 0.0f);
  EXPECT_EQ(vlad[5], 0.0f);
  // More assignments than centres: every centre, no out-of-range read.
  soft.assignments = 16;
  EXPECT_EQ(vladAggregate(rows({{1, 1}}), vocabulary, soft).size(), 6u);
}

TEST(Vlad, NoFeaturesGiveZerosAndAWrongDimensionIsRefused) {
  const VladVocabulary vocabulary(rows({{1, 0}, {0, 1}}), "test");
  const std::vector<float> empty = vladAggregate(cv::Mat(0, 2, CV_32F), vocabulary);
  EXPECT_EQ(empty, std::vector<float>(4, 0.0f));
  EXPECT_THROW(vladAggregate(rows({{1, 0, 0}}), vocabulary), std::invalid_argument);
}

TEST(Vlad, LocalFeaturesAreTheMapCellsUnitOrRaw) {
  FeatureMaps maps;
  maps.channels = 2;
  maps.height = 1;
  maps.width = 2;
  maps.values = {3, 0, 4, 0};  // Channel-major: cell 0 = (3, 4), cell 1 = (0, 0).
  const cv::Mat unit = localFeatures(maps);
  EXPECT_NEAR(unit.at<float>(0, 0), 0.6f, 1e-6f);
  EXPECT_NEAR(unit.at<float>(0, 1), 0.8f, 1e-6f);
  EXPECT_EQ(unit.at<float>(1, 0), 0.0f);  // An all-zero cell stays zero, no division by zero.
  const cv::Mat raw = localFeatures(maps, false);
  EXPECT_EQ(raw.at<float>(0, 1), 4.0f);
  EXPECT_EQ(localFeatures(FeatureMaps{}).rows, 0);
}

TEST(Vlad, KMeansFindsSeparatedClustersTheSameWayForASeed) {
  const cv::Mat samples = threeBlobs(200, 3);
  const VladVocabulary first = VladVocabulary::learn(samples, 3, "blobs", 5);
  const VladVocabulary second = VladVocabulary::learn(samples, 3, "blobs", 5);
  ASSERT_EQ(first.clusters(), 3);
  EXPECT_EQ(cv::norm(first.centres(), second.centres(), cv::NORM_INF), 0.0);
  // Every true centre has a learnt one within the noise.
  for (const cv::Mat& truth : {rows({{1, 0, 0, 0}}), rows({{0, 1, 0, 0}}), rows({{0, 0, 0, 1}})}) {
    double nearest = 1e9;
    for (int k = 0; k < 3; ++k)
      nearest = std::min(nearest, cv::norm(first.centres().row(k), truth));
    EXPECT_LT(nearest, 0.01);
  }
  EXPECT_THROW(VladVocabulary::learn(samples.rowRange(0, 2), 3, "blobs"), std::invalid_argument);
  EXPECT_THROW(VladVocabulary::learn(cv::Mat(), 3, "blobs"), std::invalid_argument);
}

TEST_F(VladTest, VocabularyFileRoundTripsAndDamageIsNamed) {
  const VladVocabulary vocabulary = VladVocabulary::learn(threeBlobs(50, 1), 3, "layer x");
  const std::string file = path("v.vocabulary");
  vocabulary.save(file);
  const VladVocabulary loaded = VladVocabulary::load(file);
  EXPECT_EQ(loaded.identity(), "layer x");
  EXPECT_EQ(cv::norm(loaded.centres(), vocabulary.centres(), cv::NORM_INF), 0.0);

  std::vector<char> bytes = readBytes(file);
  bytes[bytes.size() / 2] ^= 0x10;
  writeBytes(path("damaged.vocabulary"), bytes);
  try {
    VladVocabulary::load(path("damaged.vocabulary"));
    FAIL() << "a damaged vocabulary loaded";
  } catch (const VocabularyFileError& error) {
    EXPECT_NE(std::string(error.what()).find("damaged.vocabulary"), std::string::npos);
  }
  EXPECT_EQ(readBytes(path("damaged.vocabulary")), bytes);  // Reported, never rewritten.
  writeBytes(path("short.vocabulary"), std::vector<char>(bytes.begin(), bytes.begin() + 20));
  EXPECT_THROW(VladVocabulary::load(path("short.vocabulary")), VocabularyFileError);
  EXPECT_THROW(VladVocabulary::load(path("missing.vocabulary")), VocabularyFileError);
}

TEST_F(VladTest, BackboneAggregatesByVladWithItsOwnVocabularyOnly) {
  // Local features are the pixels' colours.
  BackboneOptions options = test::identityBackbone(path("identity.onnx"));
  options.max_landmarks = 0;
  options.engine = "opencv";
  const BackboneDescriptor grid(options);

  cv::Mat image(48, 64, CV_8UC3, cv::Scalar(200, 30, 30));
  cv::rectangle(image, cv::Rect(0, 0, 32, 48), cv::Scalar(30, 200, 30), cv::FILLED);
  const cv::Mat features = grid.vladFeatures(image);
  ASSERT_EQ(features.rows, 24 * 32);
  options.vocabulary = VladVocabulary::learn(features, 2, grid.featureIdentity());
  const BackboneDescriptor vlad(options);
  EXPECT_EQ(vlad.globalDimension(), 2 * 3);
  EXPECT_NE(vlad.describesAs(image.size()).find("VLAD over 2 centres"), std::string::npos);
  const ImageDescriptor described = vlad.describe(image);
  ASSERT_EQ(described.global.size(), 6u);
  EXPECT_NEAR(cv::norm(described.global), 1.0, 1e-5);
  EXPECT_NEAR(vlad.similarity(described, vlad.describe(image)), 1.0, 1e-6);

  options.vlad_weight = 0.5;  // The grid beside VLAD.
  EXPECT_EQ(BackboneDescriptor(options).globalDimension(), 3 * 4 * 3 + 2 * 3);

  options.vocabulary = VladVocabulary(options.vocabulary.centres(), "another network");
  EXPECT_THROW(BackboneDescriptor{options}, std::runtime_error);
}

}  // namespace
}  // namespace landmark_loop_closure
