#include "landmark_loop_closure/descriptors/broad_autoencoder.h"

#include <cmath>
#include <filesystem>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

namespace {

// Uniform in [-1, 1] from a generator whose output the C++ standard fixes, so a seed gives the
// same weights with every compiler (std::uniform_real_distribution's output is not fixed).
Eigen::MatrixXf uniformMatrix(int rows, int cols, std::mt19937* random) {
  Eigen::MatrixXf matrix(rows, cols);
  for (Eigen::Index i = 0; i < matrix.size(); ++i) {
    matrix.data()[i] = static_cast<float>((*random)() >> 8) * (2.0f / 16777216.0f) - 1.0f;
  }
  return matrix;
}

Eigen::MatrixXf withOnes(const Eigen::MatrixXf& matrix) {
  Eigen::MatrixXf extended(matrix.rows(), matrix.cols() + 1);
  extended << matrix, Eigen::VectorXf::Ones(matrix.rows());
  return extended;
}

// 0.8 / max|x|: BLS's scaling that keeps tanh out of saturation on the training data.
float tanhScale(const Eigen::MatrixXf& preactivation) {
  const float largest = preactivation.cwiseAbs().maxCoeff();
  return largest > 0.0f ? 0.8f / largest : 1.0f;
}

Eigen::MatrixXd solveSymmetric(const Eigen::MatrixXd& matrix, const Eigen::MatrixXd& right) {
  Eigen::LLT<Eigen::MatrixXd> factor(matrix);
  if (factor.info() != Eigen::Success) throw std::runtime_error("ridge system is not positive");
  return factor.solve(right);
}

}  // namespace

int BroadOptions::outputNodes() const {
  return std::max(
      1, static_cast<int>(std::lround(output_fraction * (mappedNodes() + enhancement_nodes))));
}

std::string BroadOptions::validate() const {
  std::string errors;
  const auto range = [&errors](const char* key, double value, double low, double high) {
    if (!(value >= low && value <= high)) {
      errors += std::string("advanced/descriptor/broad/") + key + " must be in [" +
                std::to_string(low) + ", " + std::to_string(high) + "] (got " +
                std::to_string(value) + ")\n";
    }
  };
  range("input_width", input_width, 4, 1024);
  range("input_height", input_height, 4, 1024);
  range("mapped_groups", mapped_groups, 1, 1000);
  range("nodes_per_group", nodes_per_group, 1, 10000);
  range("enhancement_nodes", enhancement_nodes, 1, 100000);
  range("output_fraction", output_fraction, 1e-3, 10.0);
  range("lasso_lambda", lasso_lambda, 0.0, 1e6);
  range("lasso_iterations", lasso_iterations, 1, 10000);
  range("ridge_lambda", ridge_lambda, 1e-12, 1e12);
  return errors;
}

Eigen::MatrixXf lassoAdmm(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b, double lambda,
                          int iterations, double rho) {
  const Eigen::Index n = a.cols();
  Eigen::MatrixXd gram = (a.transpose() * a).cast<double>();
  gram.diagonal().array() += rho;
  const Eigen::LLT<Eigen::MatrixXd> factor(gram);
  const Eigen::MatrixXd atb = (a.transpose() * b).cast<double>();
  Eigen::MatrixXd w, z = Eigen::MatrixXd::Zero(n, b.cols()), u = z;
  const double threshold = lambda / rho;
  for (int k = 0; k < iterations; ++k) {
    w = factor.solve(atb + rho * (z - u));
    const Eigen::MatrixXd v = w + u;
    z = v.array().sign() * (v.array().abs() - threshold).max(0.0);  // Soft threshold.
    u += w - z;
  }
  return z.cast<float>();
}

Eigen::MatrixXf randomOrthogonal(int rows, int cols, uint32_t seed) {
  std::mt19937 random(seed);
  const Eigen::MatrixXf matrix = uniformMatrix(rows, cols, &random);
  if (rows >= cols) {
    const Eigen::HouseholderQR<Eigen::MatrixXf> qr(matrix);
    return qr.householderQ() * Eigen::MatrixXf::Identity(rows, cols);
  }
  const Eigen::HouseholderQR<Eigen::MatrixXf> qr(matrix.transpose());
  return (qr.householderQ() * Eigen::MatrixXf::Identity(cols, rows)).transpose();
}

Eigen::RowVectorXf BroadModel::preprocess(const cv::Mat& image) const {
  if (image.empty() || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
    return {};
  }
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  if (grey.depth() == CV_16U) grey.convertTo(grey, CV_8U, 1.0 / 256.0);
  cv::Mat resized;
  cv::resize(grey, resized, cv::Size(options.input_width, options.input_height), 0, 0,
             cv::INTER_CUBIC);
  cv::Mat values;
  resized.convertTo(values, CV_32F, 1.0 / 255.0);
  cv::Scalar mean, deviation;
  cv::meanStdDev(values, mean, deviation);
  const double scale = deviation[0] > 1e-6 ? 1.0 / deviation[0] : 1.0;
  Eigen::RowVectorXf row(values.total());
  for (int y = 0; y < values.rows; ++y) {
    for (int x = 0; x < values.cols; ++x) {
      row(y * values.cols + x) = static_cast<float>((values.at<float>(y, x) - mean[0]) * scale);
    }
  }
  return row;
}

Eigen::MatrixXf BroadModel::mappedFeatures(const Eigen::MatrixXf& inputs) const {
  Eigen::MatrixXf mapped = withOnes(inputs) * mapping;
  mapped.rowwise() -= mapped_min;
  return mapped.array().rowwise() / mapped_range.array();
}

Eigen::MatrixXf BroadModel::enhancementFeatures(const Eigen::MatrixXf& mapped) const {
  return ((withOnes(mapped) * enhancement) * enhancement_scale).array().tanh();
}

Eigen::MatrixXf BroadModel::hidden(const Eigen::MatrixXf& inputs) const {
  const Eigen::MatrixXf mapped = mappedFeatures(inputs);
  const Eigen::MatrixXf enhanced = enhancementFeatures(mapped);
  Eigen::MatrixXf joined(inputs.rows(), mapped.cols() + enhanced.cols() + 1);
  joined << mapped, enhanced, Eigen::VectorXf::Ones(inputs.rows());
  return joined;
}

Eigen::MatrixXf BroadModel::outputLayer(const Eigen::MatrixXf& hidden_layer) const {
  return ((hidden_layer * output) * output_scale).array().tanh();
}

BroadTrainer::BroadTrainer(const BroadOptions& options) {
  const std::string problem = options.validate();
  if (!problem.empty()) throw std::invalid_argument(problem);
  model_.options = options;
}

void BroadTrainer::train(const Eigen::MatrixXf& inputs) {
  const BroadOptions& options = model_.options;
  if (inputs.rows() < 2) throw std::invalid_argument("training needs at least 2 images");
  if (inputs.cols() != model_.inputDimension()) {
    throw std::invalid_argument("training rows have " + std::to_string(inputs.cols()) +
                                " values, the model expects " +
                                std::to_string(model_.inputDimension()));
  }
  if (!inputs.allFinite()) throw std::invalid_argument("training inputs hold NaN or infinity");
  inputs_ = inputs;
  const Eigen::MatrixXf extended = withOnes(inputs);
  std::mt19937 random(options.seed);

  // Mapped features: each group's random projection, refined by a sparse autoencoder whose
  // weights (lasso, ADMM) become the group's input weights.
  const int k = options.nodes_per_group;
  model_.mapping.resize(extended.cols(), options.mappedNodes());
  for (int group = 0; group < options.mapped_groups; ++group) {
    Eigen::MatrixXf projected = extended * uniformMatrix(extended.cols(), k, &random);
    const Eigen::RowVectorXf largest = projected.cwiseAbs().colwise().maxCoeff().cwiseMax(1e-12f);
    projected = projected.array().rowwise() / largest.array();
    const Eigen::MatrixXf sparse =
        lassoAdmm(projected, extended, options.lasso_lambda, options.lasso_iterations);
    model_.mapping.middleCols(group * k, k) = sparse.transpose();
  }
  const Eigen::MatrixXf raw_mapped = extended * model_.mapping;
  model_.mapped_min = raw_mapped.colwise().minCoeff();
  model_.mapped_range = (raw_mapped.colwise().maxCoeff() - model_.mapped_min).cwiseMax(1e-12f);
  const Eigen::MatrixXf mapped = model_.mappedFeatures(inputs);

  model_.enhancement =
      randomOrthogonal(options.mappedNodes() + 1, options.enhancement_nodes, random());
  model_.enhancement_scale = tanhScale(withOnes(mapped) * model_.enhancement);
  hidden_ = model_.hidden(inputs);

  const Eigen::MatrixXf output_weights =
      randomOrthogonal(static_cast<int>(hidden_.cols()), options.outputNodes(), random());
  model_.output_scale = tanhScale(hidden_ * output_weights);
  next_seed_ = random();
  setOutputWeights(output_weights);
}

void BroadTrainer::setOutputWeights(const Eigen::MatrixXf& weights) {
  model_.output = weights;
  outputs_ = model_.outputLayer(hidden_);
  model_.output_mean = outputs_.colwise().mean();
  model_.reconstruction = solveFromScratch();
  inverse_.resize(0, 0);  // Computed when output nodes are first added (training needs none).
}

void BroadTrainer::addOutputNodes(int count) {
  if (count < 1) throw std::invalid_argument("add at least one output node");
  if (model_.empty()) throw std::logic_error("train before adding output nodes");
  addOutputNodes(randomOrthogonal(static_cast<int>(hidden_.cols()), count, next_seed_++));
}

void BroadTrainer::addOutputNodes(const Eigen::MatrixXf& weights) {
  if (model_.empty()) throw std::logic_error("train before adding output nodes");
  if (weights.rows() != hidden_.cols() || weights.cols() < 1) {
    throw std::invalid_argument("new output weights need " + std::to_string(hidden_.cols()) +
                                " rows");
  }
  const Eigen::MatrixXd old_outputs = outputs_.cast<double>();
  const Eigen::MatrixXd new_outputs =
      ((hidden_ * weights) * model_.output_scale).array().tanh().matrix().cast<double>();
  const Eigen::MatrixXd targets = inputs_.cast<double>();
  if (inverse_.size() == 0) {
    Eigen::MatrixXd system = old_outputs.transpose() * old_outputs;
    system.diagonal().array() += model_.options.ridge_lambda;
    inverse_ = solveSymmetric(system, Eigen::MatrixXd::Identity(system.rows(), system.cols()));
  }
  const Eigen::MatrixXd& p = inverse_;

  // [K B; B' C] with K = lambda I + O'O (inverse P known), B = O'Oa, C = lambda I + Oa'Oa.
  // Schur complement S = C - B' P B gives the new solution and inverse without solving K again.
  const Eigen::MatrixXd b = old_outputs.transpose() * new_outputs;
  Eigen::MatrixXd c = new_outputs.transpose() * new_outputs;
  c.diagonal().array() += model_.options.ridge_lambda;
  const Eigen::MatrixXd pb = p * b;
  const Eigen::MatrixXd schur = c - b.transpose() * pb;
  const Eigen::MatrixXd old_solution = model_.reconstruction.cast<double>();
  const Eigen::MatrixXd new_rows =
      solveSymmetric(schur, new_outputs.transpose() * targets - b.transpose() * old_solution);
  const Eigen::MatrixXd updated_rows = old_solution - pb * new_rows;
  const Eigen::MatrixXd schur_inverse =
      solveSymmetric(schur, Eigen::MatrixXd::Identity(schur.rows(), schur.cols()));

  const Eigen::Index l = p.rows();
  const Eigen::Index q = schur.rows();
  Eigen::MatrixXd inverse(l + q, l + q);
  inverse.topLeftCorner(l, l) = p + pb * schur_inverse * pb.transpose();
  inverse.topRightCorner(l, q) = -pb * schur_inverse;
  inverse.bottomLeftCorner(q, l) = inverse.topRightCorner(l, q).transpose();
  inverse.bottomRightCorner(q, q) = schur_inverse;
  inverse_ = std::move(inverse);

  Eigen::MatrixXf reconstruction(l + q, targets.cols());
  reconstruction << updated_rows.cast<float>(), new_rows.cast<float>();
  model_.reconstruction = std::move(reconstruction);
  Eigen::MatrixXf output(model_.output.rows(), l + q);
  output << model_.output, weights;
  model_.output = std::move(output);
  Eigen::MatrixXf outputs(outputs_.rows(), l + q);
  outputs << outputs_, new_outputs.cast<float>();
  outputs_ = std::move(outputs);
  model_.output_mean = outputs_.colwise().mean();
}

Eigen::MatrixXf BroadTrainer::solveFromScratch() const {
  const Eigen::MatrixXd o = outputs_.cast<double>();
  Eigen::MatrixXd system = o.transpose() * o;
  system.diagonal().array() += model_.options.ridge_lambda;
  return solveSymmetric(system, o.transpose() * inputs_.cast<double>()).cast<float>();
}

double BroadTrainer::trainingError() const {
  if (model_.empty()) return 0.0;
  return static_cast<double>((outputs_ * model_.reconstruction - inputs_).squaredNorm()) /
         static_cast<double>(inputs_.size());
}

ImageDescriptor BroadDescriptor::describe(const cv::Mat& image) const {
  ImageDescriptor descriptor;
  const Eigen::RowVectorXf input = model_.preprocess(image);
  if (input.size() == 0) return descriptor;
  Eigen::RowVectorXf output = model_.outputLayer(model_.hidden(input));
  output -= model_.output_mean;
  const float norm = output.norm();
  if (norm > 0.0f) output /= norm;
  descriptor.global.assign(output.data(), output.data() + output.size());
  return descriptor;
}

const ParameterTable<DescriptorOptions::Broad>& DescriptorOptions::Broad::parameters() {
  using O = DescriptorOptions::Broad;
  static const auto table =
      ParameterTable<O>("advanced/descriptor/broad/",
                        "type broad: FLCD-BA's broad autoencoder (methods.md section 3).")
          .text("model", &O::model,
                "file written by `lcd_train broad --bag YOUR_RUN.bag --output FILE` (trained on "
                "the keyframes the node would keep from a run of the robot's own); required for "
                "type broad.");
  return table;
}

DescriptorType broadDescriptorType() {
  DescriptorType type;
  type.name = "broad";
  type.reads = {"broad/"};
  type.summary =
      "FLCD-BA's broad autoencoder, trained by ridge regression (advanced/descriptor/broad/*)";
  type.validate = [](const DescriptorOptions& options) {
    if (options.broad.model.empty()) {
      return std::string(
          "advanced/descriptor/broad/model is empty: train one with `lcd_train broad --bag "
          "YOUR_RUN.bag --output FILE` and name it\n");
    }
    return std::string();
  };
  type.identity = [](const DescriptorOptions& options) {
    return "model_fnv1a=" + fileHash(options.broad.model);
  };
  type.make = [](const DescriptorOptions& options) {
    std::error_code absent;
    if (!std::filesystem::exists(options.broad.model, absent)) {
      throw BroadModelFileError("advanced/descriptor/broad/model " + options.broad.model +
                                " does not exist: train it with `rosrun landmark_loop_closure "
                                "lcd_train broad --bag YOUR_RUN.bag --output " +
                                options.broad.model + "`");
    }
    return std::make_shared<BroadDescriptor>(BroadModel::load(options.broad.model));
  };
  return type;
}

}  // namespace landmark_loop_closure
