#pragma once

#include <optional>
#include <string>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// How a network wants its input and which outputs the descriptor reads: a property of the model
/// file, shipped beside it as MODEL.json (model/mobilenet_v2.onnx.json), as model zoos ship their
/// preprocessing. Pixels are scaled to [0, 1], then (pixel - mean) / std per channel.
struct ModelDescription {
  int input_width = 0;
  int input_height = 0;
  std::string colour;          ///< "rgb", "bgr" or "grey".
  std::string mean;            ///< Per channel, space-separated ("0.485 0.456 0.406").
  std::string std;             ///< Per channel, space-separated.
  std::string layer;           ///< The output the descriptor is read from.
  std::string proposal_layer;  ///< Backbone: the output landmark boxes come from; "" = layer.
};

/// The description file of a model: its path with ".json" appended.
std::string modelDescriptionPath(const std::string& model_path);

/// Reads the description beside `model_path`; nothing when there is none. Throws
/// std::runtime_error naming the file and the field when it is unreadable or incomplete.
std::optional<ModelDescription> readModelDescription(const std::string& model_path);

/// Sets the preprocessing of the networks `options` runs (type backbone: descriptor/backbone's
/// model; cnn_pca: descriptor/cnn's) from their descriptions. Returns "" or the problem: a
/// network without a description, unless it is the package's own (whose values are the
/// options' defaults), or a description that cannot be read.
std::string applyModelDescriptions(DescriptorOptions* options);

}  // namespace landmark_loop_closure
