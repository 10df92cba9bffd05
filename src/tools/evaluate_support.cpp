#include "evaluate_support.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

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
  if (arguments.has("--limit")) {
    const size_t limit = static_cast<size_t>(arguments.number("--limit", 0));
    if (limit < paths.size()) paths.resize(limit);
  }
  return paths;
}

namespace {

// "cnn_pca_raw_cosine", "cnn_pca_c64", "broad_e10000": the methods of methods.md sections 2, 3.
Variant learnedVariant(const std::string& name, const Arguments& arguments,
                       const DescriptorOptions& base) {
  Variant variant;
  variant.options = base;
  DescriptorOptions& options = variant.options;
  const bool cnn = name.rfind("cnn_pca", 0) == 0;
  options.type = cnn ? "cnn_pca" : "broad";
  options.cnn.model = arguments.get("--cnn-model", options.cnn.model);
  options.cnn.whitening = arguments.get("--cnn-whitening", options.cnn.whitening);
  options.broad.model = arguments.get("--broad-model", options.broad.model);
  std::istringstream parts(name.substr(options.type.size()));
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    if (cnn && part == "raw") {
      options.cnn.whitening = "none";
    } else if (cnn && part == "cosine") {
      options.cnn.similarity = "cosine";
    } else if (cnn && part.size() > 1 && part[0] == 'c' && std::isdigit(part[1])) {
      variant.components = std::stoi(part.substr(1));
    } else if (!cnn && part.size() > 1 && part[0] == 'e' && std::isdigit(part[1])) {
      variant.broad.enhancement_nodes = std::stoi(part.substr(1));
    } else {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    }
  }
  return variant;
}

// "backbone_g3x4_m30_r30_h20_n100_i256x144_b12_p5": the pretrained backbone with grid 3x4, 30
// landmarks, re-rank weight 0.30, HOG weight 0.20, HOG alone below 100 px wide, a 256x144 input,
// layer block_12_add, landmark boxes from block_5_add.
Variant backboneVariant(const std::string& name, const Arguments& arguments,
                        const DescriptorOptions& base) {
  Variant variant;
  variant.options = base;
  DescriptorOptions& options = variant.options;
  DescriptorOptions::Backbone& backbone = options.backbone;
  options.type = "backbone";
  backbone.model = arguments.get("--backbone-model", backbone.model);
  std::istringstream parts(name.substr(options.type.size()));
  std::string part;
  const auto size = [](const std::string& text, int* first, int* second) {
    const size_t x = text.find('x');
    if (x == std::string::npos) throw std::invalid_argument("expected AxB, got '" + text + "'");
    *first = std::stoi(text.substr(0, x));
    *second = std::stoi(text.substr(x + 1));
  };
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    const std::string rest = part.substr(1);
    if (part == "paper") {
      options.shape_weighting = "paper";
    } else if (part.rfind("pca", 0) == 0 && part.size() > 3) {
      variant.whiten_components = std::stoi(part.substr(3));
    } else if (part == "hoglm") {
      backbone.landmark_features = "hog";
    } else if (part == "whole" || part == "centred") {
      backbone.normalisation = part;
    } else if (part.rfind("hog", 0) == 0) {
      size(part.substr(3), &backbone.hog_width, &backbone.hog_height);
    } else if (part[0] == 'g' && part.size() > 1) {
      size(rest, &backbone.grid_rows, &backbone.grid_cols);
    } else if (part[0] == 'i' && part.size() > 1) {
      size(rest, &backbone.input_width, &backbone.input_height);
    } else if (part.rfind("lg", 0) == 0) {
      backbone.landmark_grid = std::stoi(part.substr(2));
    } else if (part[0] == 'm' && part.size() > 1) {
      backbone.max_landmarks = std::stoi(rest);
    } else if (part[0] == 'r' && part.size() > 1) {
      backbone.rerank_weight = std::stoi(rest) / 100.0;
    } else if (part[0] == 'h' && part.size() > 1) {
      backbone.hog_weight = std::stoi(rest) / 100.0;
    } else if (part[0] == 'n' && part.size() > 1) {
      backbone.min_network_width = std::stoi(rest);
    } else if (part[0] == 'b' && part.size() > 1) {
      backbone.layer = "block_" + rest + "_add";
    } else if (part[0] == 'p' && part.size() > 1) {
      backbone.proposal_layer = "block_" + rest + "_add";
    } else {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    }
  }
  return variant;
}

}  // namespace

Variant descriptorVariant(const std::string& name, const Arguments& arguments,
                          const DescriptorOptions& base) {
  if (name.rfind("cnn_pca", 0) == 0 || name.rfind("broad", 0) == 0) {
    return learnedVariant(name, arguments, base);
  }
  if (name.rfind("backbone", 0) == 0) return backboneVariant(name, arguments, base);
  Variant variant;
  variant.options = base;
  DescriptorOptions& options = variant.options;
  options.model = arguments.get("--model", options.model);
  std::istringstream parts(name);
  std::getline(parts, options.type, '_');
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part == "paper") {
      options.shape_weighting = "paper";
    } else if (part == "per") {
      options.landmark_features = "conv_per_landmark";
      std::getline(parts, part, '_');  // "landmark"
    } else if (part == "conv2" || part == "conv3") {
      options.landmark_layer = part;
      options.landmark_features = "conv";
    } else if (part == "conv" || part == "hog") {
      options.landmark_features = part;
    } else if (part == "f32") {
      options.landmark_storage = "float32";
    } else if (part.rfind("w", 0) == 0 && part.size() > 1 && std::isdigit(part[1])) {
      options.working_width = std::stoi(part.substr(1));
      options.working_height = options.working_width * 3 / 4;
    } else if (part.rfind("patch", 0) == 0) {
      options.landmark_patch = std::stoi(part.substr(5));
    } else if (part.rfind("area", 0) == 0) {
      options.max_landmark_area = std::stoi(part.substr(4)) / 100.0;
    } else if (part.rfind("grid", 0) == 0) {
      options.landmark_grid = std::stoi(part.substr(4));
    } else if (part.rfind("m", 0) == 0) {
      options.max_landmarks = std::stoi(part.substr(1));
    } else if (options.type != "hog" || part != "whole") {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    } else {
      options.type = "hog_whole";
    }
  }
  return variant;
}

bool needsTraining(const Variant& variant) {
  const DescriptorOptions& options = variant.options;
  return (options.type == "cnn_pca" && options.cnn.whitening.empty()) ||
         (options.type == "broad" && options.broad.model.empty()) || variant.whiten_components > 0;
}

void trainWhereNeeded(Variant* variant, const std::string& name, const Training& training,
                      const std::string& output_folder) {
  DescriptorOptions& options = variant->options;
  const bool fit = options.type == "cnn_pca" && options.cnn.whitening.empty();
  const bool train = options.type == "broad" && options.broad.model.empty();
  if (!fit && !train) return;
  std::filesystem::create_directories(output_folder);
  const auto start = std::chrono::steady_clock::now();
  std::string file = output_folder + "/" + name + (fit ? ".whitening" : ".broad");
  std::string summary;
  if (fit) {
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
    extractor =
        withFittedWhitening(extractor, training.count, training.load, variant->whiten_components,
                            progressPrinter("fitting the whitening (" + name + ")"));
  }
  return extractor;
}

}  // namespace tools
}  // namespace landmark_loop_closure
