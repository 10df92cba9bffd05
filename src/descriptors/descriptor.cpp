#include "landmark_loop_closure/descriptors/descriptor.h"

#include <filesystem>
#include <stdexcept>

#include <Eigen/Core>

#include "landmark_loop_closure/common/model_directory.h"
#include "landmark_loop_closure/descriptors/registry.h"

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
  static const std::vector<std::string> types = [] {
    std::vector<std::string> names;
    for (const DescriptorType& type : descriptorRegistry()) names.push_back(type.name);
    return names;
  }();
  return types;
}

std::string defaultModelPath() { return modelDirectory() + "/calc_encoder.onnx"; }

std::string defaultBackbonePath() { return modelDirectory() + "/mobilenet_v2.onnx"; }

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
             "package's own encoder (advanced/descriptor/type landmarks), which is far weaker at "
             "night and "
             "across seasons";
  return fallback;
}

const ParameterTable<DescriptorOptions>& DescriptorOptions::parameters() {
  using O = DescriptorOptions;
  const auto types = [] {
    std::string list;
    for (const DescriptorType& type : descriptorRegistry()) {
      list += (list.empty() ? " \"" : "; \"") + type.name + "\": " + type.summary;
    }
    return list;
  };
  static const auto table =
      ParameterTable<O>("advanced/descriptor/", "")
          .word("type", &O::type, descriptorTypes(),
                "what describes a keyframe; without the fetched backbone network the node warns "
                "and runs \"landmarks\" instead. Compared in bench/README.md." +
                    types() + ".")
          .text("model", &O::model, "ONNX file; \"\" = the package's model/calc_encoder.onnx.")
          .integer("max_landmarks", &O::max_landmarks, between(1, 500),
                   "landmarks kept per image (highest conv2 activation energy first).")
          .number("max_landmark_area", &O::max_landmark_area, openBetween(0, 1, true, false),
                  "a box covering more than this fraction of the image is no landmark.")
          .integer("working_width", &O::working_width, between(32, 4096),
                   "the image the landmark patches are cut from; the network itself ...")
          .integer("working_height", &O::working_height, between(32, 4096),
                   "... always sees 160x120.")
          .integer("landmark_patch", &O::landmark_patch, between(8, 256),
                   "side of a landmark's HOG patch in pixels (a multiple of 4).")
          .integer("condition_window", &O::condition_window, between(0, 1000),
                   "keyframes whose mean global vector each keyframe's loses before it is "
                   "searched and stored (per-condition standardisation): what the camera's recent "
                   "keyframes share - night, rain, the season - stops counting as likeness, so "
                   "different places in the dark no longer match each other. 0 = off. Chosen on "
                   "Gardens Point's first half, reported on the second (bench/README.md). A "
                   "run's first keyframes are stored once the window is full, standardised by "
                   "it. Maps store the standardised vectors: a map made with another window "
                   "does not load.")
          .group(&O::cnn, Cnn::parameters())
          .group(&O::backbone, Backbone::parameters())
          .group(&O::broad, Broad::parameters());
  return table;
}

const ParameterTable<DescriptorOptions>& DescriptorOptions::evaluationParameters() {
  using O = DescriptorOptions;
  static const auto table =
      ParameterTable<O>("descriptor/", "")
          .word("landmark_features", &O::landmark_features, {"hog", "conv", "conv_per_landmark"},
                "what describes a landmark: \"hog\" of its patch of the working image (324 "
                "values), \"conv\": the conv2 maps of the shared pass inside the box (128 x grid "
                "x grid), \"conv_per_landmark\": one network pass per box (1064, ~30x slower). hog "
                "won on Gardens Point day/night (bench/README.md).")
          .integer("landmark_grid", &O::landmark_grid, between(1, 16),
                   "conv: a landmark's box resampled to grid x grid cells ...")
          .word("landmark_layer", &O::landmark_layer, {"conv2", "conv3"},
                "... of this layer's maps: \"conv2\" (128 channels) or \"conv3\" (4).")
          .word("landmark_storage", &O::landmark_storage, {"float16", "float32"},
                "\"float16\" halves the landmark bytes with no measured loss; or \"float32\".")
          .word("shape_weighting", &O::shape_weighting, {"penalise", "paper"},
                "\"penalise\" box-shape disagreement (Suenderhauf) or \"paper\" (as printed).")
          .group(&O::cnn, Cnn::evaluationParameters())
          .group(&O::backbone, Backbone::evaluationParameters());
  return table;
}

bool DescriptorOptions::reranks() const {
  return type == "landmarks" || (type == "backbone" && backbone.rerank_weight > 0.0);
}

std::string DescriptorOptions::validate() const {
  std::string errors = parameters().check(*this) + evaluationParameters().check(*this) +
                       Broad::parameters().check(broad);
  if (landmark_patch % 4 != 0) {
    errors += "advanced/descriptor/landmark_patch must be a multiple of 4 (got " +
              std::to_string(landmark_patch) + ")\n";
  }
  if (const DescriptorType* entry = findDescriptorType(type)) errors += entry->validate(*this);
  return errors;
}

std::string descriptorIdentity(const DescriptorOptions& options) {
  const DescriptorType* type = findDescriptorType(options.type);
  if (type == nullptr) return "type=" + options.type;
  std::string details = type->identity(options);
  // Maps made before the window existed (and with it off) keep their identity.
  if (options.condition_window > 0) {
    details += (details.empty() ? "" : " ") + std::string("condition_window=") +
               std::to_string(options.condition_window);
  }
  return "type=" + options.type + (details.empty() ? "" : " " + details);
}

std::shared_ptr<const DescriptorExtractor> makeDescriptorExtractor(
    const DescriptorOptions& options) {
  const DescriptorType* type = findDescriptorType(options.type);
  if (type == nullptr)
    throw std::invalid_argument("unknown descriptor type '" + options.type + "'");
  return type->make(options);
}

}  // namespace landmark_loop_closure
