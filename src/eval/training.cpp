#include "landmark_loop_closure/eval/training.h"

#include <stdexcept>
#include <vector>

namespace landmark_loop_closure {
namespace eval {

namespace {

// One row per readable image; unreadable ones are skipped.
template <typename RowOf>
Eigen::MatrixXf collectRows(size_t count, const ImageLoader& load, const Progress& progress,
                            const RowOf& row_of) {
  std::vector<Eigen::RowVectorXf> rows;
  rows.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const cv::Mat image = load(i);
    if (!image.empty()) {
      Eigen::RowVectorXf row = row_of(image);
      if (row.size() > 0) rows.push_back(std::move(row));
    }
    if (progress) progress(i + 1, count);
  }
  if (rows.size() < 2) {
    throw std::invalid_argument("training needs at least 2 readable images, got " +
                                std::to_string(rows.size()));
  }
  Eigen::MatrixXf matrix(static_cast<Eigen::Index>(rows.size()), rows.front().size());
  for (size_t i = 0; i < rows.size(); ++i) matrix.row(static_cast<Eigen::Index>(i)) = rows[i];
  return matrix;
}

class WhitenedExtractor : public DescriptorExtractor {
 public:
  WhitenedExtractor(std::shared_ptr<const DescriptorExtractor> inner, PcaWhitening whitening)
      : inner_(std::move(inner)), whitening_(std::move(whitening)) {}

  std::string name() const override { return inner_->name() + "_pca"; }
  int globalDimension() const override { return whitening_.outputDimension(); }
  bool wantsColour() const override { return inner_->wantsColour(); }
  ImageDescriptor describe(const cv::Mat& image) const override {
    ImageDescriptor descriptor = inner_->describe(image);
    if (descriptor.empty()) return descriptor;
    Eigen::VectorXf whitened = whitening_.apply(Eigen::Map<const Eigen::VectorXf>(
        descriptor.global.data(), static_cast<Eigen::Index>(descriptor.global.size())));
    if (whitened.norm() > 0.0f) whitened.normalize();
    descriptor.global.assign(whitened.data(), whitened.data() + whitened.size());
    return descriptor;
  }

 private:
  std::shared_ptr<const DescriptorExtractor> inner_;
  PcaWhitening whitening_;
};

}  // namespace

std::shared_ptr<const DescriptorExtractor> withFittedWhitening(
    std::shared_ptr<const DescriptorExtractor> inner, size_t count, const ImageLoader& load,
    int components, bool whiten, const Progress& progress) {
  const Eigen::MatrixXf globals =
      collectRows(count, load, progress, [&inner](const cv::Mat& image) {
        const std::vector<float> global = inner->describe(image).global;
        return Eigen::RowVectorXf(Eigen::Map<const Eigen::RowVectorXf>(
            global.data(), static_cast<Eigen::Index>(global.size())));
      });
  // A regulariser far above every eigenvalue divides each component by nearly the same number:
  // the projection alone, which the final normalisation leaves unscaled.
  return std::make_shared<WhitenedExtractor>(
      std::move(inner), PcaWhitening::fit(globals, components, whiten ? 1e-3 : 1e9));
}

PcaWhitening fitWhitening(const CnnGlobalDescriptor& network, size_t count, const ImageLoader& load,
                          int components, double regularisation, const Progress& progress) {
  const Eigen::MatrixXf features =
      collectRows(count, load, progress, [&network](const cv::Mat& image) {
        return Eigen::RowVectorXf(network.rawFeature(image).transpose());
      });
  return PcaWhitening::fit(features, components, regularisation);
}

VladVocabulary learnVocabulary(const BackboneDescriptor& network, size_t count,
                               const ImageLoader& load, int clusters, int samples_per_image,
                               const Progress& progress) {
  cv::Mat samples;
  for (size_t i = 0; i < count; ++i) {
    const cv::Mat image = load(i);
    if (!image.empty() && image.depth() == CV_8U) {
      const cv::Mat features = network.vladFeatures(image);
      const int step = std::max(1, features.rows / std::max(1, samples_per_image));
      for (int row = 0; row < features.rows; row += step) samples.push_back(features.row(row));
    }
    if (progress) progress(i + 1, count);
  }
  return VladVocabulary::learn(samples, clusters, network.featureIdentity());
}

BroadModel trainBroad(const BroadOptions& options, size_t count, const ImageLoader& load,
                      double* training_error, const Progress& progress) {
  BroadTrainer trainer(options);
  const Eigen::MatrixXf inputs =
      collectRows(count, load, progress,
                  [&trainer](const cv::Mat& image) { return trainer.model().preprocess(image); });
  trainer.train(inputs);
  if (training_error) *training_error = trainer.trainingError();
  return trainer.model();
}

}  // namespace eval
}  // namespace landmark_loop_closure
