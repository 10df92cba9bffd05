#include "evaluate_support.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "landmark_loop_closure/descriptors/model_description.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {
namespace tools {

using namespace landmark_loop_closure::eval;

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::istringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

Progress progressPrinter(const std::string& what) {
  auto last =
      std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
  return [what, last](size_t done, size_t total) {
    const auto now = std::chrono::steady_clock::now();
    if (done != total && now - *last < std::chrono::seconds(5)) return;
    *last = now;
    std::cerr << "lcd_evaluate: " << what << " " << done << "/" << total << "\n";
  };
}

std::vector<std::string> limited(std::vector<std::string> paths, const Arguments& arguments) {
  if (arguments.has("--skip")) {
    const size_t skip = std::min(paths.size(), static_cast<size_t>(arguments.number("--skip", 0)));
    paths.erase(paths.begin(), paths.begin() + static_cast<std::ptrdiff_t>(skip));
  }
  if (arguments.has("--limit")) {
    const size_t limit = static_cast<size_t>(arguments.number("--limit", 0));
    if (limit < paths.size()) paths.resize(limit);
  }
  return paths;
}

CameraIntrinsics readCameraInfoFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& error) {
    throw std::runtime_error(path + ": cannot read a camera_info YAML (" + error.what() + ")");
  }
  const YAML::Node data = root["camera_matrix"]["data"];
  if (!root["image_width"] || !root["image_height"] || !data || !data.IsSequence() ||
      data.size() != 9) {
    throw std::runtime_error(path +
                             ": a camera_info YAML needs image_width, image_height and "
                             "camera_matrix/data (9 values)");
  }
  CameraIntrinsics intrinsics;
  try {
    intrinsics.image_size = cv::Size(root["image_width"].as<int>(), root["image_height"].as<int>());
    intrinsics.fx = data[0].as<double>();
    intrinsics.cx = data[2].as<double>();
    intrinsics.fy = data[4].as<double>();
    intrinsics.cy = data[5].as<double>();
    // The lens, as the node takes it from camera_info.
    const YAML::Node distortion = root["distortion_coefficients"]["data"];
    if (distortion && distortion.IsSequence()) {
      intrinsics.setLens(root["distortion_model"] ? root["distortion_model"].as<std::string>() : "",
                         distortion.as<std::vector<double>>());
    }
  } catch (const std::exception& error) {
    throw std::runtime_error(path + ": camera_info values are not numbers (" + error.what() + ")");
  }
  if (const std::string problem = intrinsics.problem(); !problem.empty()) {
    throw std::runtime_error(path + ": " + problem);
  }
  return intrinsics;
}

Variant descriptorVariant(const std::string& name, const Arguments& arguments,
                          const DescriptorOptions& base) {
  Variant variant;
  DescriptorOptions options = base;
  options.model = arguments.get("--model", options.model);
  options.cnn.model = arguments.get("--cnn-model", options.cnn.model);
  options.cnn.whitening = arguments.get("--cnn-whitening", options.cnn.whitening);
  options.broad.model = arguments.get("--broad-model", options.broad.model);
  options.backbone.model = arguments.get("--backbone-model", options.backbone.model);
  options.backbone.vocabulary = arguments.get("--vocabulary", options.backbone.vocabulary);
  // A network named here brings its preprocessing in its description (MODEL.json).
  for (const char* network_type : {"backbone", "cnn_pca"}) {
    DescriptorOptions described = options;
    described.type = network_type;
    const std::string problem = applyModelDescriptions(&described);
    if (!problem.empty()) throw std::invalid_argument(problem);
    options.backbone = described.backbone;
    options.cnn = described.cnn;
  }
  // Training settings are this tool's, not the descriptor's: "_pcaN" whitens any global vector,
  // "cnn_pca_cN" keeps N whitened dimensions, "broad_eN" trains N enhancement nodes.
  const DescriptorType* type = descriptorTypeOfVariant(name);
  const auto numbered = [](const std::string& part, const std::string& prefix) {
    return part.size() > prefix.size() && part.rfind(prefix, 0) == 0 &&
           std::all_of(part.begin() + static_cast<std::ptrdiff_t>(prefix.size()), part.end(),
                       [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
  };
  std::string descriptor_name = type == nullptr ? name : type->name;
  std::istringstream parts(type == nullptr ? std::string() : name.substr(type->name.size()));
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    if (numbered(part, "pca")) {
      variant.whiten_components = std::stoi(part.substr(3));
    } else if (numbered(part, "proj")) {
      variant.whiten_components = std::stoi(part.substr(4));
      variant.whiten = false;
    } else if (type->name == "backbone" && numbered(part, "vlad")) {
      variant.vocabulary_clusters = std::stoi(part.substr(4));
    } else if (type->name == "cnn_pca" && numbered(part, "c")) {
      variant.components = std::stoi(part.substr(1));
    } else if (type->name == "broad" && numbered(part, "e")) {
      variant.broad.enhancement_nodes = std::stoi(part.substr(1));
    } else {
      descriptor_name += "_" + part;
    }
  }
  variant.options = applyDescriptorVariant(descriptor_name, options);
  return variant;
}

bool needsTraining(const Variant& variant) {
  const DescriptorOptions& options = variant.options;
  return (options.type == "cnn_pca" && options.cnn.whitening.empty()) ||
         (options.type == "broad" && options.broad.model.empty()) ||
         variant.whiten_components > 0 ||
         (variant.vocabulary_clusters > 0 && options.backbone.vocabulary.empty());
}

void trainWhereNeeded(Variant* variant, const std::string& name, const Training& training,
                      const std::string& output_folder) {
  DescriptorOptions& options = variant->options;
  const bool fit = options.type == "cnn_pca" && options.cnn.whitening.empty();
  const bool train = options.type == "broad" && options.broad.model.empty();
  const bool cluster = variant->vocabulary_clusters > 0 && options.backbone.vocabulary.empty();
  if (!fit && !train && !cluster) return;
  std::filesystem::create_directories(output_folder);
  const auto start = std::chrono::steady_clock::now();
  std::string file = output_folder + "/" + name +
                     (fit       ? ".whitening"
                      : cluster ? ".vocabulary"
                                : ".broad");
  std::string summary;
  if (cluster) {
    const auto network =
        std::dynamic_pointer_cast<const BackboneDescriptor>(makeDescriptorExtractor(options));
    if (!network) throw std::invalid_argument(name + ": only the backbone takes a vocabulary");
    const VladVocabulary vocabulary =
        learnVocabulary(*network, training.count, training.load, variant->vocabulary_clusters, 64,
                        progressPrinter("learning the vocabulary (" + name + ")"));
    vocabulary.save(file);
    options.backbone.vocabulary = file;
    summary = std::to_string(vocabulary.clusters()) + " centres";
  } else if (fit) {
    DescriptorOptions::Cnn raw = options.cnn;
    raw.whitening = "none";
    const CnnGlobalDescriptor network(cnnGlobalOptions(raw));
    const PcaWhitening whitening =
        fitWhitening(network, training.count, training.load, variant->components, 1e-3,
                     progressPrinter("fitting the whitening (" + name + ")"));
    whitening.save(file, network.featureIdentity());
    options.cnn.whitening = file;
    summary = std::to_string(whitening.inputDimension()) + " -> " +
              std::to_string(whitening.outputDimension()) + " dimensions";
  } else {
    double error = 0.0;
    const BroadModel model = trainBroad(variant->broad, training.count, training.load, &error,
                                        progressPrinter("training (" + name + ")"));
    model.save(file);
    options.broad.model = file;
    summary = std::to_string(model.outputDimension()) + " output nodes, reconstruction error " +
              std::to_string(error);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "lcd_evaluate: %s trained on %zu images (%s) in %.1f s (%s)\n", name.c_str(),
               training.count, training.source.c_str(), seconds, summary.c_str());
}

std::shared_ptr<const DescriptorExtractor> makeVariantExtractor(Variant* variant,
                                                                const std::string& name,
                                                                const Training& training,
                                                                const std::string& output_folder) {
  if (needsTraining(*variant) && training.count == 0) {
    throw std::invalid_argument(
        name +
        " learns from images: give --train-images DIR (images that are not evaluated), or "
        "--train-on-eval to train on the evaluation images themselves (which flatters it)");
  }
  trainWhereNeeded(variant, name, training, output_folder);
  const std::string problem = variant->options.validate();
  if (!problem.empty()) throw std::invalid_argument(problem);
  std::shared_ptr<const DescriptorExtractor> extractor = makeDescriptorExtractor(variant->options);
  if (variant->whiten_components > 0) {
    extractor = withFittedWhitening(extractor, training.count, training.load,
                                    variant->whiten_components, variant->whiten,
                                    progressPrinter("fitting the whitening (" + name + ")"));
  }
  return extractor;
}

}  // namespace tools
}  // namespace landmark_loop_closure
