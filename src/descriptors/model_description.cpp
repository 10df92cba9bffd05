#include "landmark_loop_closure/descriptors/model_description.h"

#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <opencv2/core/persistence.hpp>

namespace landmark_loop_closure {

namespace {

std::string numbersText(const cv::FileNode& node, const std::string& file,
                        const std::string& field) {
  std::ostringstream text;
  if (node.isSeq()) {
    for (const cv::FileNode& value : node) {
      if (!value.isReal() && !value.isInt()) {
        throw std::runtime_error(file + ": '" + field + "' must hold numbers");
      }
      text << (text.tellp() > 0 ? " " : "") << static_cast<double>(value);
    }
  } else if (node.isReal() || node.isInt()) {
    text << static_cast<double>(node);
  } else {
    throw std::runtime_error(file + ": '" + field + "' must be a number or a list of numbers");
  }
  return text.str();
}

template <typename Network>
std::string apply(const std::string& model_path, bool packaged, const char* key, Network* network) {
  // A missing model file is the loader's to report, with its own words.
  if (!std::filesystem::exists(model_path)) return "";
  std::optional<ModelDescription> description;
  try {
    description = readModelDescription(model_path);
  } catch (const std::exception& error) {
    return error.what();
  }
  if (!description) {
    if (packaged) return "";  // The options' defaults are the package's network's.
    return std::string(key) + " " + model_path + " has no description " +
           modelDescriptionPath(model_path) +
           ": write one with its input_width, input_height, colour (rgb, bgr or grey), mean, "
           "std and layer (model/mobilenet_v2.onnx.json is an example)";
  }
  network->input_width = description->input_width;
  network->input_height = description->input_height;
  network->colour = description->colour;
  network->mean = description->mean;
  network->std = description->std;
  network->layer = description->layer;
  if constexpr (std::is_same_v<Network, DescriptorOptions::Backbone>) {
    network->proposal_layer = description->proposal_layer;
  }
  return "";
}

}  // namespace

std::string modelDescriptionPath(const std::string& model_path) { return model_path + ".json"; }

std::optional<ModelDescription> readModelDescription(const std::string& model_path) {
  const std::string path = modelDescriptionPath(model_path);
  if (!std::filesystem::exists(path)) return std::nullopt;
  cv::FileStorage file;
  try {
    file.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
  } catch (const cv::Exception& error) {
    throw std::runtime_error(path + ": not a readable JSON description (" + error.err + ")");
  }
  if (!file.isOpened()) throw std::runtime_error(path + ": cannot be read");
  const cv::FileNode root = file.root();
  const auto required = [&](const char* field) {
    const cv::FileNode node = root[field];
    if (node.empty() || node.isNone()) {
      throw std::runtime_error(path + ": the field '" + field + "' is missing");
    }
    return node;
  };
  const auto text = [&](const char* field) {
    const cv::FileNode node = required(field);
    if (!node.isString()) throw std::runtime_error(path + ": '" + field + "' must be text");
    return static_cast<std::string>(node);
  };
  const auto size = [&](const char* field) {
    const cv::FileNode node = required(field);
    if (!node.isInt() || static_cast<int>(node) < 8 || static_cast<int>(node) > 4096) {
      throw std::runtime_error(path + ": '" + field + "' must be a whole number in [8, 4096]");
    }
    return static_cast<int>(node);
  };
  ModelDescription description;
  description.input_width = size("input_width");
  description.input_height = size("input_height");
  description.colour = text("colour");
  if (description.colour != "rgb" && description.colour != "bgr" && description.colour != "grey") {
    throw std::runtime_error(path + ": 'colour' must be rgb, bgr or grey (got '" +
                             description.colour + "')");
  }
  description.mean = numbersText(required("mean"), path, "mean");
  description.std = numbersText(required("std"), path, "std");
  description.layer = text("layer");
  if (!root["proposal_layer"].empty()) description.proposal_layer = text("proposal_layer");
  return description;
}

std::string applyModelDescriptions(DescriptorOptions* options) {
  if (options->type == "backbone") {
    return apply(backboneModelPath(options->backbone), options->backbone.model.empty(),
                 "advanced/descriptor/backbone/model", &options->backbone);
  }
  if (options->type == "cnn_pca") {
    return apply(cnnModelPath(options->cnn), options->cnn.model.empty(),
                 "advanced/descriptor/cnn/model", &options->cnn);
  }
  return "";
}

}  // namespace landmark_loop_closure
