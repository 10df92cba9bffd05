#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// A broad autoencoder model file that cannot be used: missing, truncated, corrupt, newer.
class BroadModelFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Shape and training settings of the broad autoencoder (methods.md section 3, FLCD-BA).
struct BroadOptions {
  int input_width = 40;  ///< Images are resized (cubic) to this, grey, /255, standardised.
  int input_height = 30;
  int mapped_groups = 10;          ///< n groups of mapped features ...
  int nodes_per_group = 90;        ///< ... of this many nodes: M = 900 as in the paper.
  int enhancement_nodes = 2000;    ///< E (the paper: 10 000; 2 000 is ~10x faster per frame).
  double output_fraction = 0.667;  ///< alpha: the output layer has alpha * (M + E) nodes.
  double lasso_lambda = 1e-3;      ///< Sparsity of the mapped features' refinement.
  int lasso_iterations = 50;       ///< ADMM iterations.
  double ridge_lambda = 1e-2;      ///< Regulariser of the reconstruction weights.
  uint32_t seed = 1;               ///< Random weights; the same seed and data give the same model.

  int mappedNodes() const { return mapped_groups * nodes_per_group; }
  int outputNodes() const;
  std::string validate() const;
};

/// Solves min_W 0.5 ||A W - B||^2 + lambda ||W||_1 (entry-wise) by ADMM with penalty rho.
Eigen::MatrixXf lassoAdmm(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b, double lambda,
                          int iterations, double rho = 1.0);

/// The trained network: everything needed to describe an image, and the reconstruction weights.
struct BroadModel {
  BroadOptions options;
  Eigen::MatrixXf mapping;          ///< (D + 1) x M: refined input weights, all groups.
  Eigen::RowVectorXf mapped_min;    ///< M: scales each mapped node to [0, 1] on training data.
  Eigen::RowVectorXf mapped_range;  ///< M.
  Eigen::MatrixXf enhancement;      ///< (M + 1) x E, orthogonal.
  float enhancement_scale = 1.0f;
  Eigen::MatrixXf output;  ///< (M + E + 1) x L, orthogonal.
  float output_scale = 1.0f;
  Eigen::RowVectorXf output_mean;  ///< L: the training mean of the output layer.
  Eigen::MatrixXf reconstruction;  ///< L x D: W_f, the ridge solution.

  int inputDimension() const { return options.input_width * options.input_height; }
  int outputDimension() const { return static_cast<int>(output.cols()); }
  bool empty() const { return output.size() == 0; }

  /// The preprocessed row vector of an 8- or 16-bit grey, BGR or BGRA image (else empty).
  Eigen::RowVectorXf preprocess(const cv::Mat& image) const;
  /// Layers for a batch of preprocessed rows (N x D).
  Eigen::MatrixXf mappedFeatures(const Eigen::MatrixXf& inputs) const;
  Eigen::MatrixXf enhancementFeatures(const Eigen::MatrixXf& mapped) const;
  /// [Z | H | 1]: the output layer's input.
  Eigen::MatrixXf hidden(const Eigen::MatrixXf& inputs) const;
  Eigen::MatrixXf outputLayer(const Eigen::MatrixXf& hidden) const;

  /// Little-endian binary with a checksum, written atomically.
  void save(const std::string& path) const;
  /// Throws BroadModelFileError naming the file and what is wrong.
  static BroadModel load(const std::string& path);
};

/// Trains a BroadModel and keeps what incremental learning needs (the training inputs, the
/// output layer and, from the first increment on, the ridge inverse (lambda I + O^T O)^-1).
class BroadTrainer {
 public:
  explicit BroadTrainer(const BroadOptions& options);

  /// `inputs`: preprocessed rows (BroadModel::preprocess), at least 2. Throws
  /// std::invalid_argument on too few rows, a wrong width or non-finite values.
  void train(const Eigen::MatrixXf& inputs);
  /// Adds `count` output nodes and updates the reconstruction weights and the ridge inverse in
  /// block form (Schur complement), without solving the whole system again.
  void addOutputNodes(int count);
  /// Appends the given output weights ((M + E + 1) x count) instead of random ones (tests).
  void addOutputNodes(const Eigen::MatrixXf& weights);

  const BroadModel& model() const { return model_; }
  /// Reconstruction error on the training inputs: mean squared error per value.
  double trainingError() const;
  /// The ridge solution computed from scratch for the current output layer (tests compare the
  /// incremental update with it).
  Eigen::MatrixXf solveFromScratch() const;

 private:
  void setOutputWeights(const Eigen::MatrixXf& weights);

  BroadModel model_;
  Eigen::MatrixXf inputs_;   // N x D
  Eigen::MatrixXf hidden_;   // N x (M + E + 1)
  Eigen::MatrixXf outputs_;  // N x L
  Eigen::MatrixXd inverse_;  // L x L: (lambda I + O^T O)^-1, once output nodes are added.
  uint32_t next_seed_ = 0;
};

/// Columns (or, when wider than tall, rows) orthonormal; entries from uniform [-1, 1] first.
Eigen::MatrixXf randomOrthogonal(int rows, int cols, uint32_t seed);

/// FLCD-BA's descriptor: the output layer of a trained broad autoencoder, centred on its training
/// mean and L2-normalised; cosine similarity.
class BroadDescriptor : public DescriptorExtractor {
 public:
  explicit BroadDescriptor(BroadModel model) : model_(std::move(model)) {}

  std::string name() const override { return "broad"; }
  int globalDimension() const override { return model_.outputDimension(); }
  ImageDescriptor describe(const cv::Mat& image) const override;
  const BroadModel& model() const { return model_; }

 private:
  BroadModel model_;
};

}  // namespace landmark_loop_closure
