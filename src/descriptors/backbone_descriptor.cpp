#include "landmark_loop_closure/descriptors/backbone_descriptor.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "landmark_loop_closure/descriptors/model_description.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

namespace {

// Scales a unit vector's entries in place so that its part weighs `weight` in a dot product.
void weightPart(float* begin, float* end, double weight) {
  const float factor = static_cast<float>(std::sqrt(weight));
  for (float* value = begin; value != end; ++value) *value *= factor;
}

void normaliseGrid(std::vector<float>* grid, int channels, GridNormalisation normalisation) {
  const size_t cells = grid->size() / static_cast<size_t>(channels);
  if (normalisation == GridNormalisation::kCentred) {
    for (int c = 0; c < channels; ++c) {
      float sum = 0.0f;
      for (size_t k = 0; k < cells; ++k) sum += (*grid)[k * channels + c];
      for (size_t k = 0; k < cells; ++k) (*grid)[k * channels + c] -= sum / cells;
    }
  }
  if (normalisation != GridNormalisation::kWhole) {
    for (size_t k = 0; k < cells; ++k) {
      float* const cell = grid->data() + k * static_cast<size_t>(channels);
      normaliseL2(cell, cell + channels);
    }
  }
  normaliseL2(grid);
}

}  // namespace

std::vector<float> gridPool(const FeatureMaps& maps, int grid_rows, int grid_cols, double power) {
  std::vector<float> pooled(static_cast<size_t>(grid_rows) * grid_cols * maps.channels, 0.0f);
  if (maps.empty()) return pooled;
  const bool plain_mean = power == 1.0;
  for (int row = 0; row < grid_rows; ++row) {
    const int y0 = row * maps.height / grid_rows;
    const int y1 = std::max(y0 + 1, (row + 1) * maps.height / grid_rows);
    for (int col = 0; col < grid_cols; ++col) {
      const int x0 = col * maps.width / grid_cols;
      const int x1 = std::max(x0 + 1, (col + 1) * maps.width / grid_cols);
      const double area = static_cast<double>((y1 - y0) * (x1 - x0));
      float* cell = pooled.data() + (static_cast<size_t>(row) * grid_cols + col) * maps.channels;
      for (int c = 0; c < maps.channels; ++c) {
        const float* channel = maps.channel(c);
        double sum = 0.0;
        for (int y = y0; y < std::min(y1, maps.height); ++y) {
          for (int x = x0; x < std::min(x1, maps.width); ++x) {
            const double value = channel[y * maps.width + x];
            sum += plain_mean ? value : std::copysign(std::pow(std::abs(value), power), value);
          }
        }
        const double mean = sum / area;
        cell[c] = static_cast<float>(
            plain_mean ? mean : std::copysign(std::pow(std::abs(mean), 1.0 / power), mean));
      }
    }
  }
  return pooled;
}

BackboneDescriptor::BackboneDescriptor(const BackboneOptions& options)
    : options_(options),
      hog_(options.hog_size, cv::Size(16, 16), cv::Size(8, 8), cv::Size(8, 8), 9) {
  if (options_.proposal_layer.empty()) options_.proposal_layer = options_.layer;
  const size_t colour_channels = options.colour == "grey" ? 1 : 3;
  if (options.mean.size() != colour_channels || options.std.size() != colour_channels) {
    throw std::runtime_error("the backbone's mean and std need " + std::to_string(colour_channels) +
                             " values each");
  }
  if (options.grid_rows < 1 || options.grid_cols < 1) {
    throw std::runtime_error("the backbone's grid needs at least one row and one column");
  }
  net_ = loadOnnxNetwork(options.model_path);
  if (options_.engine == "auto") {
    // Before OpenCV's first pass: its layer fusion may rewrite the weights oneDNN reads.
    std::vector<std::string> wanted = {options_.layer};
    if (options_.proposal_layer != options_.layer) wanted.push_back(options_.proposal_layer);
    std::string why;
    fast_net_ = OneDnnMobileNet::create(net_, options_.input_size, wanted, &why);
    engine_note_ = fast_net_ ? "oneDNN" : "OpenCV's dnn (oneDNN cannot: " + why + ")";
  } else {
    engine_note_ = "OpenCV's dnn (engine opencv)";
  }
  std::vector<FeatureMaps> outputs;
  try {
    outputs = forward(cv::Mat(options.input_size, CV_8UC3, cv::Scalar(128, 128, 128)));
  } catch (const std::exception& error) {
    throw std::runtime_error("the ONNX model " + options.model_path + " gives no outputs '" +
                             options_.layer + "' and '" + options_.proposal_layer + "' for a " +
                             std::to_string(options.input_size.width) + "x" +
                             std::to_string(options.input_size.height) + " input: " + error.what());
  }
  channels_ = outputs[0].channels;
  std::ostringstream identity;
  identity << "model_fnv1a=" << fileHash(options.model_path) << " layer=" << options_.layer
           << " input=" << options.input_size.width << "x" << options.input_size.height
           << " colour=" << options.colour << " channels=" << channels_
           << " local=" << (options.vlad.unit_features ? "unit" : "raw");
  feature_identity_ = identity.str();
  if (!options_.vocabulary.empty() && options_.vocabulary.identity() != feature_identity_) {
    throw std::runtime_error("the VLAD vocabulary was learnt on other features (" +
                             options_.vocabulary.identity() + "), not this network's (" +
                             feature_identity_ + "): learn one with lcd_train vocabulary");
  }
  global_dimension_ = gridDimension() + hogDimension();
}

int BackboneDescriptor::cellsDimension() const {
  const bool keeps_grid = options_.vocabulary.empty() || options_.vlad_weight < 1.0;
  return keeps_grid ? options_.grid_rows * options_.grid_cols * channels_ : 0;
}

int BackboneDescriptor::gridDimension() const {
  const int vlad = options_.vocabulary.empty() ? 0 : options_.vocabulary.clusters() * channels_;
  return cellsDimension() + vlad;
}

int BackboneDescriptor::hogDimension() const {
  const bool uses_hog = options_.hog_weight > 0.0 || options_.min_network_width > 0;
  return uses_hog ? static_cast<int>(hog_.getDescriptorSize()) : 0;
}

std::vector<FeatureMaps> BackboneDescriptor::forward(const cv::Mat& image,
                                                     BackboneStageTimes* times) const {
  Clock::time_point start = Clock::now();
  const cv::Mat blob =
      networkInputBlob(image, options_.input_size, options_.colour, options_.mean, options_.std);
  if (times) times->network_input = millisecondsSince(start);
  std::vector<cv::Mat> outputs;
  {
    MutexLock lock(net_mutex_);
    start = Clock::now();
    if (fast_net_) {
      outputs = fast_net_->forward(blob);
      if (outputs.size() == 1) outputs.push_back(outputs.front());  // Proposal layer = layer.
    } else {
      net_.setInput(blob);
      net_.forward(outputs, std::vector<cv::String>{options_.layer, options_.proposal_layer});
    }
    if (times) times->network = millisecondsSince(start);
  }
  return {featureMapsFromBlob(outputs[0]), featureMapsFromBlob(outputs[1])};
}

cv::Mat BackboneDescriptor::vladFeatures(const cv::Mat& image) const {
  if (image.empty() || image.depth() != CV_8U) return {};
  return localFeatures(forward(image)[0], options_.vlad.unit_features);
}

FeatureMaps BackboneDescriptor::appearanceMaps(const cv::Mat& image) const {
  if (image.empty() || image.depth() != CV_8U) return {};
  return forward(image)[0];
}

std::string BackboneDescriptor::describesAs(cv::Size image) const {
  std::ostringstream text;
  text << "backbone: " << image.width << "x" << image.height << " images ";
  if (hogDimension() > 0 && image.width < options_.min_network_width) {
    text << "are narrower than advanced/descriptor/backbone/min_network_width ("
         << options_.min_network_width << " px): the HOG alone describes them ("
         << options_.hog_size.width << "x" << options_.hog_size.height
         << " window), the network does not run; set "
         << "min_network_width to 0 to run it anyway";
    return text.str();
  }
  text << "go through the network (" << options_.layer << " at " << options_.input_size.width << "x"
       << options_.input_size.height << " on " << engine_note_ << ", ";
  if (options_.vocabulary.empty()) {
    text << options_.grid_rows << "x" << options_.grid_cols << " grid)";
  } else {
    if (cellsDimension() > 0) {
      text << options_.grid_rows << "x" << options_.grid_cols << " grid and ";
    }
    text << "VLAD over " << options_.vocabulary.clusters() << " centres)";
  }
  if (hogDimension() > 0 && options_.hog_weight > 0.0) {
    text << " with a whole-image HOG at weight " << options_.hog_weight;
  }
  if (options_.max_landmarks > 0) text << ", up to " << options_.max_landmarks << " landmarks";
  return text.str();
}

ImageDescriptor BackboneDescriptor::describe(const cv::Mat& image) const {
  return describe(image, nullptr);
}

ImageDescriptor BackboneDescriptor::describe(const cv::Mat& image,
                                             BackboneStageTimes* times) const {
  ImageDescriptor descriptor;
  if (image.empty() || image.depth() != CV_8U) return descriptor;
  const int hog_dimension = hogDimension();
  const bool network_sees_enough = image.cols >= options_.min_network_width;
  descriptor.global.assign(static_cast<size_t>(global_dimension_), 0.0f);
  float* const grid_begin = descriptor.global.data();
  float* const hog_begin = grid_begin + gridDimension();

  double network_weight = 1.0 - (hog_dimension > 0 ? options_.hog_weight : 0.0);
  if (hog_dimension > 0 && !network_sees_enough) network_weight = 0.0;
  if (network_weight > 0.0) {
    const std::vector<FeatureMaps> maps = forward(image, times);
    Clock::time_point start = Clock::now();
    float* const vlad_begin = grid_begin + cellsDimension();
    if (vlad_begin != grid_begin) {
      std::vector<float> grid =
          gridPool(maps[0], options_.grid_rows, options_.grid_cols, options_.cell_pooling_power);
      normaliseGrid(&grid, channels_, options_.normalisation);
      std::copy(grid.begin(), grid.end(), grid_begin);
    }
    if (!options_.vocabulary.empty()) {
      const std::vector<float> vlad = vladAggregate(
          localFeatures(maps[0], options_.vlad.unit_features), options_.vocabulary, options_.vlad);
      std::copy(vlad.begin(), vlad.end(), vlad_begin);
      if (vlad_begin != grid_begin) {
        weightPart(grid_begin, vlad_begin, 1.0 - options_.vlad_weight);
        weightPart(vlad_begin, hog_begin, options_.vlad_weight);
      }
    }
    weightPart(grid_begin, hog_begin, network_weight);
    if (times) times->grid = millisecondsSince(start);

    if (options_.max_landmarks > 0) {
      const cv::Size box_frame(kBoxFrameWidth, kBoxFrameHeight);
      LandmarkProposalOptions proposal_options;
      proposal_options.max_landmarks = options_.max_landmarks;
      proposal_options.max_area_fraction = options_.max_landmark_area;
      proposal_options.min_side_cells = 1;  // Backbone cells are coarse (16 px of the input).
      start = Clock::now();
      for (const LandmarkProposal& proposal :
           proposeLandmarks(maps[1], box_frame, proposal_options)) {
        descriptor.landmark_boxes.push_back(proposal.box);
      }
      if (times) times->landmark_proposals = millisecondsSince(start);
      start = Clock::now();
      cv::Mat features = options_.hog_landmarks
                             ? describeLandmarksByHog(toWorkingImage(image, 320, 240), box_frame,
                                                      descriptor.landmark_boxes, 32)
                             : describeLandmarks(maps[0], box_frame, descriptor.landmark_boxes,
                                                 options_.landmark_grid);
      if (options_.float16_features && !features.empty()) features.convertTo(features, CV_16F);
      descriptor.landmark_features = features;
      if (times) times->landmark_features = millisecondsSince(start);
    }
  }
  if (hog_dimension > 0 && network_weight < 1.0) {
    const Clock::time_point start = Clock::now();
    const cv::Mat working =
        toWorkingImage(image, options_.hog_size.width, options_.hog_size.height);
    std::vector<float> hog;
    hog_.compute(working, hog);
    normaliseL2(&hog);
    std::copy(hog.begin(), hog.end(), hog_begin);
    weightPart(hog_begin, hog_begin + hog_dimension, 1.0 - network_weight);
    if (times) times->hog = millisecondsSince(start);
  }
  normaliseL2(&descriptor.global);
  return descriptor;
}

double BackboneDescriptor::similarity(const ImageDescriptor& query,
                                      const ImageDescriptor& candidate) const {
  const double global = cosineSimilarity(query.global, candidate.global);
  if (options_.rerank_weight <= 0.0) return global;
  const double landmarks =
      landmarkSimilarity(query.landmark_boxes, query.landmark_features, candidate.landmark_boxes,
                         candidate.landmark_features, options_.weighting);
  return (1.0 - options_.rerank_weight) * global + options_.rerank_weight * landmarks;
}

const ParameterTable<DescriptorOptions::Backbone>& DescriptorOptions::Backbone::parameters() {
  using O = DescriptorOptions::Backbone;
  static const auto table =
      ParameterTable<O>(
          "advanced/descriptor/backbone/",
          "type backbone: the landmark-ConvNet on a pretrained ImageNet network "
          "(MobileNetV2 from the npm package nsfwjs, MIT; scripts/fetch_backbone.sh).")
          .text("model", &O::model,
                "ONNX file; \"\" = the package's model/mobilenet_v2.onnx. Any ONNX network with "
                "named feature-map outputs works (README: bring your own).")
          .integer("grid_rows", &O::grid_rows, between(1, 16),
                   "global descriptor: the layer average-pooled over rows x cols cells ...")
          .integer("grid_cols", &O::grid_cols, between(1, 16),
                   "... (3x4x96 = 1152 values); the spatial layout is what survives night.")
          .integer("max_landmarks", &O::max_landmarks, between(0, 500),
                   "landmark boxes from the activations (8-connected components, energy = mean "
                   "activation), for ~match_image and re-ranking; 0 = none.")
          .number("hog_weight", &O::hog_weight, between(0, 1),
                  "share of a whole-image HOG's cosine in the global score.")
          .integer("min_network_width", &O::min_network_width, between(0, 4096),
                   "images narrower than this (px) are described by the HOG alone: at 64 px "
                   "wide the network loses to the HOG (Nordland's 64x32), from 96 px it wins "
                   "(Gardens Point scaled down; bench/README).")
          .word("engine", &O::engine, {"auto", "opencv"},
                "what runs the network: \"auto\" = oneDNN (libdnnl) where it can run it (a Keras "
                "MobileNetV2 whose output agrees with OpenCV's), 3-4x faster on one core; OpenCV's "
                "dnn elsewhere. \"opencv\": OpenCV's dnn always. The node logs which at its first "
                "image.")
          .integer("hog_width", &O::hog_width, between(16, 512),
                   "the HOG's window: the image is resized to it (multiples of 8); ...")
          .integer("hog_height", &O::hog_height, between(16, 512),
                   "16x16 blocks, 8 px cells and stride, 9 bins: 3168 values.");
  return table;
}

const ParameterTable<DescriptorOptions::Backbone>&
DescriptorOptions::Backbone::evaluationParameters() {
  using O = DescriptorOptions::Backbone;
  static const auto table =
      ParameterTable<O>("descriptor/backbone/", "")
          .word("normalisation", &O::normalisation, {"cells", "whole", "centred"},
                "\"cells\": each cell L2-normalised, then the whole (won on Gardens Point); "
                "\"whole\": the whole vector only; \"centred\": each channel's mean over the cells "
                "removed first (bench/README.md has all three).")
          .number("cell_pooling_power", &O::cell_pooling_power, between(1, 16),
                  "how a cell pools its map cells: 1 = the mean; p > 1 = the signed generalised "
                  "mean sign(m) |m|^(1/p), m = mean of sign(x) |x|^p (GeM that stays defined "
                  "for the layer's negative values), towards the strongest activation as p grows.")
          .text("vocabulary", &O::vocabulary,
                "VLAD instead of the grid: a vocabulary file written by `lcd_train vocabulary` "
                "(k-means of the layer's local features on unlabelled images); each local feature "
                "is assigned to its nearest centres and the residuals summed per centre (centres "
                "x channels values). \"\" = the grid.")
          .integer("vlad_assignments", &O::vlad_assignments, between(1, 16),
                   "nearest centres a local feature is shared between (1 = hard assignment).")
          .word(
              "vlad_features", &O::vlad_features, {"unit", "raw"},
              "local features L2-normalised before assignment (\"unit\") or as the layer gives "
              "them (\"raw\": weak cells weigh less); the vocabulary must be learnt the same way.")
          .number("vlad_weight", &O::vlad_weight, between(0, 1),
                  "VLAD's share of the network's part; below 1 the grid is kept beside it.")
          .integer("landmark_grid", &O::landmark_grid, between(1, 8),
                   "a landmark is the layer's maps inside its box, grid x grid cells ...")
          .word("landmark_features", &O::landmark_features, {"backbone", "hog"},
                "... (\"backbone\"), or \"hog\": the HOG of its 32x32 patch of the image at "
                "320x240 (324 values), as the package's own encoder does.")
          .number("rerank_weight", &O::rerank_weight, between(0, 1),
                  "final score = (1 - w) * global + w * landmark similarity. 0: landmarks do not "
                  "re-rank (they lost on Gardens Point and the corridor).");
  return table;
}

namespace {

std::string validateBackbone(const DescriptorOptions& options) {
  const DescriptorOptions::Backbone& backbone = options.backbone;
  std::string errors = DescriptorOptions::Backbone::parameters().check(backbone) +
                       DescriptorOptions::Backbone::evaluationParameters().check(backbone);
  // The preprocessing comes from the model's description (MODEL.json): its problems name it.
  const std::string described = modelDescriptionPath(backboneModelPath(backbone)) + ": ";
  if (backbone.layer.empty()) errors += described + "layer is empty\n";
  if (backbone.hog_width % 8 != 0 || backbone.hog_height % 8 != 0) {
    errors += "advanced/descriptor/backbone/hog_width and hog_height must be multiples of 8 (got " +
              std::to_string(backbone.hog_width) + "x" + std::to_string(backbone.hog_height) +
              ")\n";
  }
  if (backbone.rerank_weight > 0 && backbone.max_landmarks == 0) {
    errors +=
        "re-ranking (rerank_weight > 0) needs advanced/descriptor/backbone/max_landmarks > 0\n";
  }
  return errors + validateNetworkInput(described, backbone.input_width, backbone.input_height,
                                       backbone.colour, backbone.mean, backbone.std);
}

// The variant name's parts: "backbone_g3x4_m30_r30_h20_n100_i256x144_b12_p5" is grid 3x4, 30
// landmarks, re-rank weight 0.30, HOG weight 0.20, the HOG alone below 100 px wide, a 256x144
// input, layer block_12_add, landmark boxes from block_5_add.
bool applyBackboneVariantPart(const std::string& part, DescriptorOptions* options) {
  DescriptorOptions::Backbone& backbone = options->backbone;
  const auto size = [](const std::string& text, int* first, int* second) {
    const size_t x = text.find('x');
    if (x == std::string::npos) throw std::invalid_argument("expected AxB, got '" + text + "'");
    *first = std::stoi(text.substr(0, x));
    *second = std::stoi(text.substr(x + 1));
  };
  const std::string rest = part.substr(1);
  if (part == "paper") {
    options->shape_weighting = "paper";
  } else if (part == "hoglm") {
    backbone.landmark_features = "hog";
  } else if (part.rfind("soft", 0) == 0 && part.size() > 4) {
    backbone.vlad_assignments = std::stoi(part.substr(4));
  } else if (part == "vraw") {
    backbone.vlad_features = "raw";
  } else if (part.rfind("vw", 0) == 0 && part.size() > 2) {
    backbone.vlad_weight = std::stoi(part.substr(2)) / 100.0;
  } else if (part.rfind("gem", 0) == 0 && part.size() > 3) {
    backbone.cell_pooling_power = std::stoi(part.substr(3)) / 10.0;
  } else if (part == "whole" || part == "centred") {
    backbone.normalisation = part;
  } else if (part.rfind("hog", 0) == 0 && part.size() > 3) {
    size(part.substr(3), &backbone.hog_width, &backbone.hog_height);
  } else if (part.size() < 2) {
    return false;
  } else if (part[0] == 'g') {
    size(rest, &backbone.grid_rows, &backbone.grid_cols);
  } else if (part[0] == 'i') {
    size(rest, &backbone.input_width, &backbone.input_height);
  } else if (part.rfind("lg", 0) == 0) {
    backbone.landmark_grid = std::stoi(part.substr(2));
  } else if (part[0] == 'm') {
    backbone.max_landmarks = std::stoi(rest);
  } else if (part[0] == 'r') {
    backbone.rerank_weight = std::stoi(rest) / 100.0;
  } else if (part[0] == 'h') {
    backbone.hog_weight = std::stoi(rest) / 100.0;
  } else if (part[0] == 'n') {
    backbone.min_network_width = std::stoi(rest);
  } else if (part[0] == 'b') {
    backbone.layer = "block_" + rest + "_add";
  } else if (part[0] == 'p') {
    backbone.proposal_layer = "block_" + rest + "_add";
  } else {
    return false;
  }
  return true;
}

}  // namespace

DescriptorType backboneDescriptorType() {
  DescriptorType type;
  type.name = "backbone";
  type.reads = {"backbone/", "max_landmark_area", "shape_weighting", "landmark_storage"};
  type.summary = "the landmark-ConvNet on a pretrained network (advanced/descriptor/backbone/*)";
  type.validate = validateBackbone;
  type.identity = [](const DescriptorOptions& options) {
    std::ostringstream identity;
    const DescriptorOptions::Backbone& b = options.backbone;
    identity << "model_fnv1a=" << fileHash(backboneModelPath(b)) << " layer=" << b.layer
             << " proposal_layer=" << b.proposal_layer << " input=" << b.input_width << "x"
             << b.input_height << " colour=" << b.colour << " mean=" << b.mean << " std=" << b.std
             << " grid=" << b.grid_rows << "x" << b.grid_cols
             << " normalisation=" << b.normalisation;
    if (b.cell_pooling_power != 1.0) identity << " cell_pooling_power=" << b.cell_pooling_power;
    if (!b.vocabulary.empty()) {
      identity << " vocabulary_fnv1a=" << fileHash(b.vocabulary)
               << " vlad_assignments=" << b.vlad_assignments << " vlad_features=" << b.vlad_features
               << " vlad_weight=" << b.vlad_weight;
    }
    identity << " max_landmarks=" << b.max_landmarks << " landmark_grid=" << b.landmark_grid
             << " landmark_features=" << b.landmark_features
             << " max_landmark_area=" << options.max_landmark_area
             << " shape_weighting=" << options.shape_weighting
             << " landmark_storage=" << options.landmark_storage << " hog_weight=" << b.hog_weight
             << " min_network_width=" << b.min_network_width << " hog=" << b.hog_width << "x"
             << b.hog_height;
    return identity.str();
  };
  type.make = [](const DescriptorOptions& options) {
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
    backbone.cell_pooling_power = b.cell_pooling_power;
    if (!b.vocabulary.empty()) backbone.vocabulary = VladVocabulary::load(b.vocabulary);
    backbone.vlad.assignments = b.vlad_assignments;
    backbone.vlad.unit_features = b.vlad_features == "unit";
    backbone.vlad_weight = b.vlad_weight;
    backbone.max_landmarks = b.max_landmarks;
    backbone.landmark_grid = b.landmark_grid;
    backbone.hog_landmarks = b.landmark_features == "hog";
    backbone.max_landmark_area = options.max_landmark_area;
    backbone.weighting =
        options.shape_weighting == "paper" ? ShapeWeighting::kPaper : ShapeWeighting::kPenalise;
    backbone.rerank_weight = b.rerank_weight;
    backbone.hog_weight = b.hog_weight;
    backbone.min_network_width = b.min_network_width;
    backbone.engine = b.engine;
    backbone.hog_size = cv::Size(b.hog_width, b.hog_height);
    backbone.float16_features = options.landmark_storage == "float16";
    return std::make_shared<BackboneDescriptor>(backbone);
  };
  type.apply_variant_part = applyBackboneVariantPart;
  return type;
}

}  // namespace landmark_loop_closure
