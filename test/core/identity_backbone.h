#pragma once

// A backbone whose network is the identity on RGB (a 1x1 convolution and ReLU, written by
// onnx_test_model.h): its "features" are the input's colours, so what the descriptor computes
// from them can be checked by hand.
#include <string>

#include "landmark_loop_closure/descriptors/backbone_descriptor.h"
#include "onnx_test_model.h"

namespace landmark_loop_closure {
namespace test {

/// Writes the network to `model_path`; a 32x24 input, the network alone (no HOG at any width).
inline BackboneOptions identityBackbone(const std::string& model_path) {
  writeOneByOneConvNet(model_path, 3, 24, 32, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0});
  BackboneOptions options;
  options.model_path = model_path;
  options.layer = "features";
  options.input_size = cv::Size(32, 24);
  options.hog_weight = 0.0;
  options.min_network_width = 0;
  return options;
}

}  // namespace test
}  // namespace landmark_loop_closure
