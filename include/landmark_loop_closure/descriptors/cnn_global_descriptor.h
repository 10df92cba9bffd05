#pragma once

#include <string>
#include <vector>

#include <opencv2/dnn.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/pca_whitening.h"

namespace landmark_loop_closure {

/// How a feature-map layer becomes one vector.
enum class FeaturePooling {
  kAverage,  ///< Mean of each channel (global average pooling, as ResNet's own head).
  kMax,      ///< Maximum of each channel.
  kNone,     ///< Every value, flattened (for small maps such as the package encoder's conv3).
};

/// Similarity of two whitened, L2-normalised vectors.
enum class GlobalSimilarity {
  kDistance,  ///< The paper's S = 1 - D / max(D) with D the Euclidean distance; online max(D)
              ///< is its bound for unit vectors, 2. Ranks exactly as cosine does.
  kCosine,
};

struct CnnGlobalOptions {
  std::string model_path;         ///< Any ONNX network OpenCV's dnn module runs.
  std::string layer;              ///< Output the vector is read from; "" = the last layer.
  cv::Size input_size{224, 224};  ///< The network's input, width x height.
  std::string colour = "rgb";     ///< Channel order the network expects: rgb, bgr or grey.
  std::vector<double> mean{0.485, 0.456, 0.406};  ///< Per channel, pixels scaled to [0, 1].
  std::vector<double> std{0.229, 0.224, 0.225};   ///< Per channel: (pixel - mean) / std.
  FeaturePooling pooling = FeaturePooling::kAverage;
  std::string whitening_path;  ///< PCA whitening fitted by lcd_fit_whitening; "" = none.
  GlobalSimilarity similarity = GlobalSimilarity::kDistance;
};

/// Methods.md section 2: a CNN's layer pooled into one global vector, L2-normalised, then PCA
/// whitened and normalised again. Without a whitening file the normalised vector itself is the
/// descriptor (what lcd_fit_whitening fits on).
class CnnGlobalDescriptor : public DescriptorExtractor {
 public:
  /// Throws std::runtime_error naming the file when the model cannot be loaded, lacks the layer,
  /// or the whitening file does not fit it.
  explicit CnnGlobalDescriptor(const CnnGlobalOptions& options);

  std::string name() const override { return "cnn_pca"; }
  int globalDimension() const override { return global_dimension_; }
  /// `image`: 8-bit grey, BGR or BGRA; converted to the network's colour order.
  ImageDescriptor describe(const cv::Mat& image) const override;
  double globalScore(double cosine) const override;
  bool wantsColour() const override { return options_.colour != "grey"; }

  /// The pooled layer, L2-normalised, before whitening.
  Eigen::VectorXf rawFeature(const cv::Mat& image) const;
  int rawDimension() const { return raw_dimension_; }
  /// What the raw features depend on (model bytes, layer, input, normalisation, pooling); a
  /// whitening file records it and is refused for other features.
  std::string featureIdentity() const { return feature_identity_; }

 private:
  CnnGlobalOptions options_;
  PcaWhitening whitening_;
  int raw_dimension_ = 0;
  int global_dimension_ = 0;
  std::string feature_identity_;
  mutable Mutex net_mutex_;  // cv::dnn::Net::forward is not safe to call concurrently.
  mutable cv::dnn::Net net_ GUARDED_BY(net_mutex_);
};

/// An 8-bit grey, BGR or BGRA image as a network's 1xCxHxW float input: converted to `colour`
/// ("rgb", "bgr" or "grey"), resized to `size` (area averaging when shrinking), pixels scaled to
/// [0, 1], then (pixel - mean) / deviation per channel.
cv::Mat networkInputBlob(const cv::Mat& image, cv::Size size, const std::string& colour,
                         const std::vector<double>& mean, const std::vector<double>& deviation);

/// Problems with a network's preprocessing (its description, MODEL.json): the input size, the
/// colour word, and its mean and std for that colour (one mean and one std > 0 per channel), one
/// line each naming `prefix` + field; "" = usable.
std::string validateNetworkInput(const std::string& prefix, int width, int height,
                                 const std::string& colour, const std::string& mean,
                                 const std::string& deviation);

/// The ONNX network in `path`, set up for OpenCV's own CPU backend. Throws std::runtime_error
/// naming the file when it cannot be loaded.
cv::dnn::Net loadOnnxNetwork(const std::string& path);

}  // namespace landmark_loop_closure
