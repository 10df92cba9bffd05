#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include "landmark_loop_closure/descriptors/pca_whitening.h"

namespace landmark_loop_closure {
namespace {

// Samples of mean + rotation * diag(scales) * z, z standard normal: the covariance's
// eigenvectors are the rotation's columns, its eigenvalues the squared scales.
Eigen::MatrixXf gaussianSamples(int count, const Eigen::VectorXf& mean,
                                const Eigen::MatrixXf& rotation, const Eigen::VectorXf& scales,
                                unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<float> normal;
  Eigen::MatrixXf samples(count, mean.size());
  for (int i = 0; i < count; ++i) {
    Eigen::VectorXf z(mean.size());
    for (int k = 0; k < z.size(); ++k) z(k) = normal(random);
    samples.row(i) = (mean + rotation * scales.asDiagonal() * z).transpose();
  }
  return samples;
}

Eigen::MatrixXf randomRotation(int size, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<float> normal;
  Eigen::MatrixXf matrix(size, size);
  for (int i = 0; i < matrix.size(); ++i) matrix.data()[i] = normal(random);
  return Eigen::HouseholderQR<Eigen::MatrixXf>(matrix).householderQ();
}

Eigen::MatrixXd sampleCovariance(const Eigen::MatrixXf& samples) {
  const Eigen::MatrixXd data = samples.cast<double>();
  const Eigen::MatrixXd centred = data.rowwise() - data.colwise().mean();
  return centred.transpose() * centred / static_cast<double>(samples.rows() - 1);
}

TEST(PcaWhitening, RecoversKnownAxesAndVariances) {
  const Eigen::Vector3f mean(5.0f, -2.0f, 1.0f);
  const Eigen::MatrixXf rotation = randomRotation(3, 7);
  const Eigen::Vector3f scales(3.0f, 1.0f, 0.2f);
  const Eigen::MatrixXf samples = gaussianSamples(20000, mean, rotation, scales, 1);

  const PcaWhitening whitening = PcaWhitening::fit(samples, 3);
  ASSERT_EQ(whitening.outputDimension(), 3);
  EXPECT_LT((whitening.mean() - mean).norm(), 0.05f);
  const float expected_values[] = {9.0f, 1.0f, 0.04f};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(whitening.eigenvalues()(k), expected_values[k], 0.05f * expected_values[k]);
    // Eigenvectors are defined up to sign.
    EXPECT_GT(std::abs(whitening.components().row(k).dot(rotation.col(k))), 0.99f) << k;
  }
  EXPECT_NEAR(whitening.explainedVariance(), 1.0, 1e-6);
}

TEST(PcaWhitening, WhitenedTrainingDataHasUnitCovariance) {
  const Eigen::VectorXf mean = Eigen::VectorXf::LinSpaced(6, -1.0f, 4.0f);
  Eigen::VectorXf scales(6);
  scales << 10.0f, 5.0f, 2.0f, 1.0f, 0.5f, 0.1f;
  const Eigen::MatrixXf samples = gaussianSamples(3000, mean, randomRotation(6, 3), scales, 2);
  const PcaWhitening whitening = PcaWhitening::fit(samples, 4);
  ASSERT_EQ(whitening.outputDimension(), 4);
  Eigen::MatrixXf whitened(samples.rows(), 4);
  for (int i = 0; i < samples.rows(); ++i) {
    whitened.row(i) = whitening.apply(samples.row(i).transpose()).transpose();
  }
  const Eigen::MatrixXd covariance = sampleCovariance(whitened);
  EXPECT_LT((covariance - Eigen::MatrixXd::Identity(4, 4)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(whitened.colwise().mean().cwiseAbs().maxCoeff(), 1e-3f);
  // Four of six components keep most, not all, of the variance.
  const double total = scales.array().square().sum();
  const double kept = scales.head(4).array().square().sum();
  EXPECT_NEAR(whitening.explainedVariance(), kept / total, 0.02);
}

TEST(PcaWhitening, FewerSamplesThanValuesMatchesTheCovarianceSolution) {
  // 20 samples of 50 values: fitted through the 20 x 20 Gram matrix; the covariance's own
  // eigen-decomposition must agree.
  std::mt19937 random(5);
  std::normal_distribution<float> normal;
  Eigen::MatrixXf samples(20, 50);
  for (int i = 0; i < samples.size(); ++i) samples.data()[i] = normal(random) * (1 + i % 7);
  const PcaWhitening whitening = PcaWhitening::fit(samples, 100);
  EXPECT_EQ(whitening.outputDimension(), 19);  // At most N - 1 directions vary.

  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> direct(sampleCovariance(samples));
  for (int k = 0; k < 19; ++k) {
    const double value = direct.eigenvalues()(49 - k);
    EXPECT_NEAR(whitening.eigenvalues()(k), value, 1e-3 * value) << k;
    const Eigen::VectorXf vector = direct.eigenvectors().col(49 - k).cast<float>();
    EXPECT_GT(std::abs(whitening.components().row(k).dot(vector)), 0.999f) << k;
  }
}

TEST(PcaWhitening, RegularisationTamesDirectionsWithoutVariance) {
  // Two values, the second constant: unregularised whitening would divide by ~0.
  Eigen::MatrixXf samples(100, 2);
  for (int i = 0; i < 100; ++i) samples.row(i) << static_cast<float>(i % 10), 3.0f;
  const PcaWhitening whitening = PcaWhitening::fit(samples, 2, 1e-3);
  Eigen::Vector2f moved(4.5f, 3.001f);  // A tiny change along the constant value.
  const Eigen::VectorXf whitened = whitening.apply(moved);
  EXPECT_TRUE(whitened.allFinite());
  EXPECT_LT(std::abs(whitened(1)), 0.2f);
}

TEST(PcaWhitening, RefusesBadInput) {
  EXPECT_THROW(PcaWhitening::fit(Eigen::MatrixXf::Ones(1, 4), 2), std::invalid_argument);
  EXPECT_THROW(PcaWhitening::fit(Eigen::MatrixXf::Random(10, 4), 0), std::invalid_argument);
  Eigen::MatrixXf with_nan = Eigen::MatrixXf::Random(10, 4);
  with_nan(3, 2) = std::nanf("");
  EXPECT_THROW(PcaWhitening::fit(with_nan, 2), std::invalid_argument);
  const PcaWhitening whitening = PcaWhitening::fit(Eigen::MatrixXf::Random(10, 4), 2);
  EXPECT_THROW(whitening.apply(Eigen::VectorXf::Ones(3)), std::invalid_argument);
}

class PcaWhiteningFile : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ =
        std::filesystem::temp_directory_path() / ("llc_whitening_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string path(const std::string& name) const { return (directory_ / name).string(); }

  std::filesystem::path directory_;
};

TEST_F(PcaWhiteningFile, RoundTripAppliesIdentically) {
  const PcaWhitening fitted = PcaWhitening::fit(Eigen::MatrixXf::Random(200, 12), 5, 1e-4);
  fitted.save(path("w.whitening"), "model=abc layer=conv3");
  const PcaWhitening loaded = PcaWhitening::load(path("w.whitening"), "model=abc layer=conv3");
  EXPECT_EQ(loaded.outputDimension(), 5);
  EXPECT_EQ(loaded.regularisation(), 1e-4);
  const Eigen::VectorXf input = Eigen::VectorXf::Random(12);
  EXPECT_EQ(fitted.apply(input), loaded.apply(input));
  EXPECT_NO_THROW(PcaWhitening::load(path("w.whitening"), ""));
}

TEST_F(PcaWhiteningFile, RefusesOtherFeaturesAndDamagedFiles) {
  const PcaWhitening fitted = PcaWhitening::fit(Eigen::MatrixXf::Random(50, 8), 4);
  fitted.save(path("w.whitening"), "layer=conv3");
  try {
    PcaWhitening::load(path("w.whitening"), "layer=conv2");
    FAIL() << "a whitening for other features was accepted";
  } catch (const WhiteningFileError& error) {
    EXPECT_NE(std::string(error.what()).find(path("w.whitening")), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("other features"), std::string::npos);
  }
  EXPECT_THROW(PcaWhitening::load(path("missing.whitening"), ""), WhiteningFileError);

  std::ifstream in(path("w.whitening"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto write = [this](const std::string& name, const std::string& content) {
    std::ofstream(path(name), std::ios::binary) << content;
    return path(name);
  };
  EXPECT_THROW(PcaWhitening::load(write("short", bytes.substr(0, bytes.size() / 2)), ""),
               WhiteningFileError);
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  EXPECT_THROW(PcaWhitening::load(write("flipped", flipped), ""), WhiteningFileError);
  EXPECT_THROW(PcaWhitening::load(write("empty", ""), ""), WhiteningFileError);
  EXPECT_THROW(PcaWhitening::load(write("text", "not a whitening file at all"), ""),
               WhiteningFileError);
}

}  // namespace
}  // namespace landmark_loop_closure
