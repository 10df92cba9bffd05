// The backbone's network run by oneDNN instead of OpenCV's dnn module.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/dnn.hpp>

namespace landmark_loop_closure {

/// MobileNetV2 as Keras names its layers (the package's backbone, scripts/convert_backbone.py),
/// up to the named outputs, run by oneDNN (Debian's libdnnl): each batch normalisation folded into
/// its convolution, ReLU6 and the residual additions fused into the convolutions, activations in
/// the layouts oneDNN picks for this CPU. Same numbers as OpenCV's dnn to float rounding, several
/// times faster on one core (bench/README.md). Weights are taken from OpenCV's parse of the
/// ONNX file. Not thread-safe: the caller serialises forward().
class OneDnnMobileNet {
 public:
  /// The network for `net` at `input` size (width x height), giving `outputs` (Keras layer names,
  /// e.g. block_12_add). Null, with the reason in `why`, when this build has no oneDNN, when
  /// `net` is not a Keras MobileNetV2 holding those outputs, or when its output for a test input
  /// differs from OpenCV's (then OpenCV's dnn stays in charge).
  static std::unique_ptr<OneDnnMobileNet> create(cv::dnn::Net& net, cv::Size input,
                                                 const std::vector<std::string>& outputs,
                                                 std::string* why);
  ~OneDnnMobileNet();

  /// `blob`: 1x3xHxW float at the input size. One 1xCxhxw float Mat per output, in order.
  std::vector<cv::Mat> forward(const cv::Mat& blob);

  /// Whether this build can use oneDNN at all.
  static bool available();

 private:
  struct Implementation;
  explicit OneDnnMobileNet(std::unique_ptr<Implementation> implementation);
  std::unique_ptr<Implementation> implementation_;
};

}  // namespace landmark_loop_closure
