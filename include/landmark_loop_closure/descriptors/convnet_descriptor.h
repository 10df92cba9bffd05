#pragma once

#include <string>

#include <opencv2/dnn.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/landmarks.h"

namespace landmark_loop_closure {

/// What describes a landmark once its box is known.
enum class LandmarkFeatures {
  kHog,              ///< HOG of the box's patch of the working image (what CALC's encoder
                     ///< learns to predict).
  kConvMapCrop,      ///< The maps of one pass over the whole image, resampled inside the box.
  kConvPerLandmark,  ///< One network pass over each box's patch; its descriptor layer.
};

/// Where describe() spends its time, in milliseconds (for the pipeline benchmark).
struct DescribeStageTimes {
  double prepare = 0.0;    ///< Grey conversion and resizing to the working and network sizes.
  double network = 0.0;    ///< The forward pass.
  double proposals = 0.0;  ///< Landmark boxes from the proposal layer.
  double landmark_features = 0.0;
};

struct ConvNetOptions {
  std::string model_path;                  ///< ONNX file; input 1x1x120x160 grey in [0, 1].
  std::string proposal_layer = "conv2";    ///< Output whose activations give landmark boxes.
  std::string descriptor_layer = "conv3";  ///< Output that describes the image and landmarks.
  bool landmarks = true;                   ///< false: whole-image descriptor only (CALC).
  LandmarkProposalOptions proposals;
  int landmark_grid = 2;            ///< Cells per side when cropping the shared map.
  bool crop_proposal_layer = true;  ///< Crops from the proposal layer, else the descriptor layer.
  LandmarkFeatures features = LandmarkFeatures::kHog;
  cv::Size working_size{320, 240};  ///< Image the HOG patches are cut from.
  int hog_patch_side = 32;          ///< Pixels per side of a landmark's HOG patch.
  bool float16_features = true;     ///< Store landmark features as float16 (half the memory).
  ShapeWeighting weighting = ShapeWeighting::kPenalise;
};

/// Descriptors from a convolutional encoder run by OpenCV's dnn module from an ONNX file (the
/// package's CALC-style encoder, or any network whose named outputs are feature maps):
/// the global descriptor is the descriptor layer's output, centred and L2-normalised; landmarks
/// are proposed from the proposal layer and described from the same forward pass or by HOG of
/// their patch of the working image. Landmark boxes are in the network input's 160x120 frame.
class ConvNetDescriptor : public DescriptorExtractor {
 public:
  static constexpr int kWidth = 160;
  static constexpr int kHeight = 120;

  /// Throws std::runtime_error naming the file when the model cannot be loaded or lacks a layer.
  explicit ConvNetDescriptor(const ConvNetOptions& options);

  std::string name() const override { return options_.landmarks ? "landmarks" : "calc"; }
  int globalDimension() const override { return global_dimension_; }
  ImageDescriptor describe(const cv::Mat& image) const override { return describe(image, nullptr); }
  /// describe(), recording the time of each stage in `times` when not null.
  ImageDescriptor describe(const cv::Mat& image, DescribeStageTimes* times) const;
  double similarity(const ImageDescriptor& query, const ImageDescriptor& candidate) const override;
  bool reranks() const override { return options_.landmarks; }

  /// The named outputs for a 160x120 grey image (exposed for tests and pictures).
  std::vector<FeatureMaps> forward(const cv::Mat& working_image) const;

 private:
  cv::Mat describeLandmarksByNetwork(const cv::Mat& network_input,
                                     const std::vector<cv::Rect2f>& boxes) const;

  ConvNetOptions options_;
  int global_dimension_ = 0;
  mutable Mutex net_mutex_;  // cv::dnn::Net::forward is not safe to call concurrently.
  mutable cv::dnn::Net net_ GUARDED_BY(net_mutex_);
};

}  // namespace landmark_loop_closure
