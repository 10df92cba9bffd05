#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/SVD>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/descriptors/broad_autoencoder.h"

namespace landmark_loop_closure {
namespace {

// A small network, so each test trains in milliseconds.
BroadOptions smallOptions() {
  BroadOptions options;
  options.input_width = 16;
  options.input_height = 12;
  options.mapped_groups = 3;
  options.nodes_per_group = 8;
  options.enhancement_nodes = 40;
  options.output_fraction = 0.5;
  return options;
}

// A scene of grey rectangles; the same seed gives the same scene.
cv::Mat scene(int seed, int width = 160, int height = 120) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(100));
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> x(0, width - 10), y(0, height - 10), side(6, width / 4),
      level(0, 255);
  for (int i = 0; i < 25; ++i) {
    cv::rectangle(image, cv::Rect(x(random), y(random), side(random), side(random)),
                  cv::Scalar(level(random)), cv::FILLED);
  }
  return image;
}

Eigen::MatrixXf trainingRows(const BroadModel& shape, int count, int first_seed = 100) {
  Eigen::MatrixXf rows(count, shape.inputDimension());
  for (int i = 0; i < count; ++i) rows.row(i) = shape.preprocess(scene(first_seed + i));
  return rows;
}

TEST(LassoAdmm, MatchesTheClosedFormForOrthonormalColumns) {
  // With A'A = I the lasso solution is the soft-thresholded A'B.
  const Eigen::MatrixXf a = randomOrthogonal(60, 8, 3);
  const Eigen::MatrixXf b = Eigen::MatrixXf::Random(60, 5);
  const double lambda = 0.1;
  const Eigen::MatrixXf atb = a.transpose() * b;
  const Eigen::MatrixXf expected =
      atb.array().sign() * (atb.array().abs() - static_cast<float>(lambda)).max(0.0f);
  const Eigen::MatrixXf solved = lassoAdmm(a, b, lambda, 300);
  EXPECT_LT((solved - expected).cwiseAbs().maxCoeff(), 1e-4f);
  EXPECT_GT((solved.array() == 0.0f).count(), 0);  // Sparse: some weights exactly zero.
}

TEST(LassoAdmm, WithoutPenaltyIsLeastSquares) {
  const Eigen::MatrixXf a = Eigen::MatrixXf::Random(50, 6);
  const Eigen::MatrixXf b = Eigen::MatrixXf::Random(50, 3);
  const Eigen::MatrixXf expected = a.colPivHouseholderQr().solve(b);
  EXPECT_LT((lassoAdmm(a, b, 0.0, 500) - expected).cwiseAbs().maxCoeff(), 1e-3f);
}

TEST(RandomOrthogonal, TallHasOrthonormalColumnsWideOrthonormalRows) {
  const Eigen::MatrixXf tall = randomOrthogonal(30, 10, 1);
  EXPECT_TRUE((tall.transpose() * tall).isApprox(Eigen::MatrixXf::Identity(10, 10), 1e-5f));
  const Eigen::MatrixXf wide = randomOrthogonal(10, 30, 2);
  EXPECT_TRUE((wide * wide.transpose()).isApprox(Eigen::MatrixXf::Identity(10, 10), 1e-5f));
  EXPECT_EQ(randomOrthogonal(5, 5, 7), randomOrthogonal(5, 5, 7));  // Seeded.
}

TEST(BroadTrainer, RidgeWeightsEqualADirectSolve) {
  BroadTrainer trainer(smallOptions());
  const Eigen::MatrixXf inputs = trainingRows(trainer.model(), 80);
  trainer.train(inputs);
  const BroadModel& model = trainer.model();
  EXPECT_EQ(model.outputDimension(), smallOptions().outputNodes());

  // W = V diag(s / (s^2 + lambda)) U' X, from the SVD of the output layer.
  const Eigen::MatrixXd outputs = model.outputLayer(model.hidden(inputs)).cast<double>();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(outputs, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const double lambda = smallOptions().ridge_lambda;
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::VectorXd shrink = s.array() / (s.array().square() + lambda);
  const Eigen::MatrixXd direct =
      svd.matrixV() * shrink.asDiagonal() * svd.matrixU().transpose() * inputs.cast<double>();
  const double scale = direct.cwiseAbs().maxCoeff();
  EXPECT_LT((model.reconstruction.cast<double>() - direct).cwiseAbs().maxCoeff(), 1e-3 * scale);
}

TEST(BroadTrainer, IncrementalOutputNodesEqualRetraining) {
  BroadTrainer trainer(smallOptions());
  trainer.train(trainingRows(trainer.model(), 80));
  const int before = trainer.model().outputDimension();
  double error = trainer.trainingError();
  for (const int added : {4, 1, 7}) {
    trainer.addOutputNodes(added);
    const Eigen::MatrixXf retrained = trainer.solveFromScratch();
    const double scale = retrained.cwiseAbs().maxCoeff();
    EXPECT_LT((trainer.model().reconstruction - retrained).cwiseAbs().maxCoeff(), 1e-3 * scale)
        << "after adding " << added;
    // More output nodes never fit the training data worse.
    EXPECT_LE(trainer.trainingError(), error * (1 + 1e-4));
    error = trainer.trainingError();
  }
  EXPECT_EQ(trainer.model().outputDimension(), before + 12);
  EXPECT_EQ(trainer.model().output_mean.size(), before + 12);
  EXPECT_THROW(trainer.addOutputNodes(0), std::invalid_argument);
  EXPECT_THROW(trainer.addOutputNodes(Eigen::MatrixXf::Ones(3, 2)), std::invalid_argument);
}

TEST(BroadTrainer, SameSeedSameModelAndBadInputRefused) {
  BroadTrainer first(smallOptions());
  BroadTrainer second(smallOptions());
  const Eigen::MatrixXf inputs = trainingRows(first.model(), 30);
  first.train(inputs);
  second.train(inputs);
  EXPECT_EQ(first.model().reconstruction, second.model().reconstruction);
  EXPECT_EQ(first.model().output, second.model().output);

  BroadTrainer trainer(smallOptions());
  EXPECT_THROW(trainer.train(inputs.topRows(1)), std::invalid_argument);
  EXPECT_THROW(trainer.train(Eigen::MatrixXf::Ones(10, 5)), std::invalid_argument);
  Eigen::MatrixXf with_nan = inputs;
  with_nan(2, 3) = std::nanf("");
  EXPECT_THROW(trainer.train(with_nan), std::invalid_argument);
  EXPECT_THROW(trainer.addOutputNodes(3), std::logic_error);  // Not trained yet.
  BroadOptions bad = smallOptions();
  bad.enhancement_nodes = 0;
  EXPECT_NE(bad.validate().find("advanced/descriptor/broad/enhancement_nodes"), std::string::npos);
  EXPECT_THROW(BroadTrainer{bad}, std::invalid_argument);
}

TEST(BroadDescriptor, RecognisesAShiftedSceneAndRefusesBadImages) {
  BroadTrainer trainer(smallOptions());
  trainer.train(trainingRows(trainer.model(), 60));
  const BroadDescriptor extractor(trainer.model());
  EXPECT_EQ(extractor.name(), "broad");

  const cv::Mat place = scene(1);
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 3, 0, 1, 2);
  cv::warpAffine(place, shifted, shift, place.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const ImageDescriptor a = extractor.describe(place);
  ASSERT_EQ(static_cast<int>(a.global.size()), extractor.globalDimension());
  EXPECT_NEAR(extractor.similarity(a, a), 1.0, 1e-5);
  const double same_place = extractor.similarity(a, extractor.describe(shifted));
  for (int other = 2; other < 12; ++other) {
    EXPECT_GT(same_place, extractor.similarity(a, extractor.describe(scene(other)))) << other;
  }
  // Colour input is converted to grey first.
  cv::Mat colour;
  cv::cvtColor(place, colour, cv::COLOR_GRAY2BGR);
  EXPECT_NEAR(extractor.similarity(a, extractor.describe(colour)), 1.0, 1e-5);
  EXPECT_TRUE(extractor.describe(cv::Mat()).empty());
  EXPECT_TRUE(extractor.describe(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1))).empty());
  // A uniform image has no contrast to standardise: still a finite descriptor.
  const ImageDescriptor flat = extractor.describe(cv::Mat(120, 160, CV_8UC1, cv::Scalar(7)));
  for (const float value : flat.global) ASSERT_TRUE(std::isfinite(value));
}

class BroadModelFile : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ =
        std::filesystem::temp_directory_path() / ("llc_broad_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string path(const std::string& name) const { return (directory_ / name).string(); }
  std::filesystem::path directory_;
};

TEST_F(BroadModelFile, RoundTripDescribesIdenticallyAndDamageIsRefused) {
  BroadTrainer trainer(smallOptions());
  trainer.train(trainingRows(trainer.model(), 30));
  trainer.model().save(path("model.broad"));
  const BroadModel loaded = BroadModel::load(path("model.broad"));
  const cv::Mat image = scene(5);
  EXPECT_EQ(BroadDescriptor(trainer.model()).describe(image).global,
            BroadDescriptor(loaded).describe(image).global);
  EXPECT_EQ(loaded.reconstruction, trainer.model().reconstruction);

  std::ifstream in(path("model.broad"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto write = [this](const std::string& name, const std::string& content) {
    std::ofstream(path(name), std::ios::binary) << content;
    return path(name);
  };
  EXPECT_THROW(BroadModel::load(path("missing.broad")), BroadModelFileError);
  EXPECT_THROW(BroadModel::load(write("short", bytes.substr(0, bytes.size() - 100))),
               BroadModelFileError);
  std::string flipped = bytes;
  flipped[bytes.size() / 3] ^= 0x01;
  EXPECT_THROW(BroadModel::load(write("flipped", flipped)), BroadModelFileError);
  EXPECT_THROW(BroadModel::load(write("empty", "")), BroadModelFileError);
  try {
    BroadModel::load(write("other.onnx", "ONNX bytes, not ours"));
    FAIL();
  } catch (const BroadModelFileError& error) {
    EXPECT_NE(std::string(error.what()).find("other.onnx"), std::string::npos);
  }
}

}  // namespace
}  // namespace landmark_loop_closure
