// Offline training of the descriptors that learn from the user's own images: the PCA whitening of
// a CNN layer (descriptor type cnn_pca) and the broad autoencoder (descriptor type broad).
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "bag/bag_source.h"
#include "command_line.h"
#include "landmark_loop_closure/common/model_directory.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"
#include "landmark_loop_closure/descriptors/registry.h"
#include "landmark_loop_closure/eval/training.h"

namespace {

using namespace landmark_loop_closure;

// Options every command reads: the source of images, the node's parameters, the result.
const std::vector<tools::TextOption> kCommonOptions = {
    {"--images", "DIR: every image of a folder (png, jpg, ...)"},
    {"--bag", "FILE: the keyframes a node would keep from a bag"},
    {"--image-topic", "the bag's image topic (default /camera/image_raw)"},
    {"--odom-topic", "the bag's odometry topic (default /odom)"},
    {"--config", "FILE: node parameters (config/default.yaml's layout) the result is for"},
    {"--limit", "N: use the first N images"},
    {"--output", "FILE: where the result goes"},
};
const std::vector<tools::TextOption> kWhiteningOptions = {
    {"--components", "N: whitened dimensions kept (default 256; at most images - 1)"},
    {"--regularisation", "R: added to every eigenvalue, fraction of the largest (default 1e-3)"},
};
const std::vector<tools::TextOption> kBroadOptions = {
    {"--input", "WxH: image size the network sees (default 40x30)"},
    {"--groups", "N: mapped feature groups (default 10)"},
    {"--nodes", "N: nodes a group (default 90)"},
    {"--enhancement", "N: enhancement nodes (default 2000; the paper: 10000)"},
    {"--alpha", "A: output nodes = A * (mapped + enhancement) (default 0.667)"},
    {"--lasso", "L: sparse regulariser (default 1e-3)"},
    {"--ridge", "R: ridge regulariser (default 1e-2)"},
    {"--seed", "S: random seed (default 1)"},
};
const std::vector<tools::TextOption> kVocabularyOptions = {
    {"--clusters", "K: centres (default 16): the descriptor has K x the layer's channels values"},
    {"--samples", "N: local features taken from each image (default 64)"},
};

double number(const std::map<std::string, std::string>& values, const std::string& key,
              double fallback) {
  const auto it = values.find(key);
  if (it == values.end()) return fallback;
  char* end = nullptr;
  const double value = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || *end != '\0') {
    throw std::invalid_argument(key + " needs a number, not '" + it->second + "'");
  }
  return value;
}

eval::Progress progress(const std::string& what) {
  auto last = std::make_shared<std::chrono::steady_clock::time_point>();
  return [what, last](size_t done, size_t total) {
    const auto now = std::chrono::steady_clock::now();
    if (done != total && now - *last < std::chrono::seconds(5)) return;
    *last = now;
    std::cerr << "lcd_train: " << what << " " << done << "/" << total << "\n";
  };
}

struct Images {
  size_t count = 0;
  eval::ImageLoader load;
};

Images images(const std::map<std::string, std::string>& values, bool colour) {
  Images source;
  const size_t limit = static_cast<size_t>(number(values, "--limit", 0));
  if (values.count("--images")) {
    auto paths =
        std::make_shared<std::vector<std::string>>(eval::listImages(values.at("--images")));
    if (limit > 0 && limit < paths->size()) paths->resize(limit);
    source.count = paths->size();
    source.load = [paths, colour](size_t i) {
      return cv::imread((*paths)[i], colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
    };
  } else if (values.count("--bag")) {
    BagSourceOptions bag;
    bag.path = values.at("--bag");
    if (values.count("--image-topic")) bag.image_topic = values.at("--image-topic");
    if (values.count("--odom-topic")) bag.odom_topic = values.at("--odom-topic");
    auto keyframes = std::make_shared<BagKeyframes>(readBagKeyframes(bag));
    if (limit > 0 && limit < keyframes->images.size()) keyframes->images.resize(limit);
    source.count = keyframes->images.size();
    source.load = [keyframes](size_t i) { return keyframes->images[i]; };
  } else {
    throw std::invalid_argument("give --images DIR or --bag FILE");
  }
  std::cerr << "lcd_train: " << source.count << " training images\n";
  return source;
}

NodeOptions nodeOptions(const std::map<std::string, std::string>& values) {
  const std::string config = values.count("--config") ? values.at("--config") : defaultConfigFile();
  const YamlParameterSource source = YamlParameterSource::fromFile(config);
  OptionReader reader(source);
  NodeOptions node;
  readNodeOptions(&reader, &node);
  const std::string problem = reader.errors();
  if (!problem.empty()) throw std::invalid_argument(problem);
  return node;
}

int fitWhitening(const std::map<std::string, std::string>& values) {
  DescriptorOptions descriptor = nodeOptions(values).detector.descriptor;
  descriptor.type = "cnn_pca";
  descriptor.cnn.whitening = "none";
  const std::string problem = descriptor.validate();
  if (!problem.empty()) throw std::invalid_argument(problem);
  const CnnGlobalDescriptor network(cnnGlobalOptions(descriptor.cnn));
  const Images training = images(values, descriptor.cnn.colour != "grey");

  const auto start = std::chrono::steady_clock::now();
  const PcaWhitening whitening = eval::fitWhitening(
      network, training.count, training.load, static_cast<int>(number(values, "--components", 256)),
      number(values, "--regularisation", 1e-3), progress("describing"));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string output = values.count("--output") ? values.at("--output")
                                                      : cnnModelPath(descriptor.cnn) + ".whitening";
  whitening.save(output, network.featureIdentity());
  std::printf("whitening: %d -> %d dimensions, %.1f %% of the variance, fitted in %.1f s\n%s\n",
              whitening.inputDimension(), whitening.outputDimension(),
              100.0 * whitening.explainedVariance(), seconds, output.c_str());
  return 0;
}

int learnVocabulary(const std::map<std::string, std::string>& values) {
  if (!values.count("--output")) throw std::invalid_argument("vocabulary needs --output FILE");
  const std::string output = values.at("--output");
  if (std::filesystem::exists(output)) {
    throw std::invalid_argument(output + " exists; name a new file (it is not replaced)");
  }
  DescriptorOptions descriptor = nodeOptions(values).detector.descriptor;
  descriptor.type = "backbone";
  descriptor.backbone.vocabulary.clear();
  const std::string problem = descriptor.validate();
  if (!problem.empty()) throw std::invalid_argument(problem);
  const auto network =
      std::dynamic_pointer_cast<const BackboneDescriptor>(makeDescriptorExtractor(descriptor));
  const Images training = images(values, descriptor.backbone.colour != "grey");
  const auto start = std::chrono::steady_clock::now();
  const VladVocabulary vocabulary = eval::learnVocabulary(
      *network, training.count, training.load, static_cast<int>(number(values, "--clusters", 16)),
      static_cast<int>(number(values, "--samples", 64)), progress("describing"));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  vocabulary.save(output);
  std::printf("vocabulary: %d centres of %d values, learnt in %.1f s\n%s\n", vocabulary.clusters(),
              vocabulary.dimension(), seconds, output.c_str());
  return 0;
}

int trainBroad(const std::map<std::string, std::string>& values) {
  BroadOptions options;
  if (values.count("--input")) {
    const std::string size = values.at("--input");
    const size_t x = size.find('x');
    if (x == std::string::npos) throw std::invalid_argument("--input needs WxH, e.g. 40x30");
    options.input_width = std::atoi(size.substr(0, x).c_str());
    options.input_height = std::atoi(size.substr(x + 1).c_str());
  }
  options.mapped_groups = static_cast<int>(number(values, "--groups", options.mapped_groups));
  options.nodes_per_group = static_cast<int>(number(values, "--nodes", options.nodes_per_group));
  options.enhancement_nodes =
      static_cast<int>(number(values, "--enhancement", options.enhancement_nodes));
  options.output_fraction = number(values, "--alpha", options.output_fraction);
  options.lasso_lambda = number(values, "--lasso", options.lasso_lambda);
  options.ridge_lambda = number(values, "--ridge", options.ridge_lambda);
  options.seed = static_cast<uint32_t>(number(values, "--seed", options.seed));
  const std::string problem = options.validate();
  if (!problem.empty()) throw std::invalid_argument(problem);
  const Images training = images(values, false);

  const auto start = std::chrono::steady_clock::now();
  double error = 0.0;
  const BroadModel model =
      eval::trainBroad(options, training.count, training.load, &error, progress("reading"));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string output = values.count("--output") ? values.at("--output") : "broad.model";
  model.save(output);
  std::printf(
      "broad autoencoder: %d inputs, %d mapped, %d enhancement, %d output nodes; trained on %zu "
      "images in %.1f s; reconstruction error %.4f\n%s\n",
      model.inputDimension(), options.mappedNodes(), options.enhancement_nodes,
      model.outputDimension(), training.count, seconds, error, output.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Offline training of the descriptors that learn from the user's own images (no labels)."};
  app.require_subcommand(1);
  std::map<std::string, std::string> values;
  CLI::App* whitening = app.add_subcommand(
      "whitening",
      "PCA whitening of advanced/descriptor/cnn's layer (type cnn_pca), written beside the model "
      "(MODEL.whitening, where the node looks by default) or to --output");
  CLI::App* broad = app.add_subcommand(
      "broad", "a broad autoencoder (type broad) written to --output (default broad.model)");
  CLI::App* vocabulary = app.add_subcommand(
      "vocabulary",
      "a VLAD vocabulary of the backbone's layer (k-means of its local features) written to "
      "--output (required; an existing file is not replaced); lcd_evaluate --vocabulary uses it "
      "(VLAD was measured against the grid and not kept in the node)");
  for (CLI::App* command : {whitening, broad, vocabulary}) {
    tools::addTextOptions(command, kCommonOptions, &values);
  }
  tools::addTextOptions(whitening, kWhiteningOptions, &values);
  tools::addTextOptions(broad, kBroadOptions, &values);
  tools::addTextOptions(vocabulary, kVocabularyOptions, &values);
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  try {
    if (*whitening) return fitWhitening(values);
    if (*broad) return trainBroad(values);
    return learnVocabulary(values);
  } catch (const std::invalid_argument& error) {
    std::cerr << "lcd_train: " << error.what()
              << "\n(lcd_train COMMAND --help lists its options)\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "lcd_train: error: " << error.what() << "\n";
    return 1;
  }
}
