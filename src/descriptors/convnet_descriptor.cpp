#include "landmark_loop_closure/descriptors/convnet_descriptor.h"

#include <cctype>
#include <chrono>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

ConvNetDescriptor::ConvNetDescriptor(const ConvNetOptions& options) : options_(options) {
  net_ = loadOnnxNetwork(options.model_path);
  std::vector<FeatureMaps> outputs;
  try {
    outputs = forward(cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(128)));
  } catch (const cv::Exception& error) {
    throw std::runtime_error("the ONNX model " + options.model_path + " has no outputs named '" +
                             options.proposal_layer + "' and '" + options.descriptor_layer +
                             "' for a 1x1x120x160 input: " + error.what());
  }
  global_dimension_ = static_cast<int>(outputs[1].values.size());
}

std::vector<FeatureMaps> ConvNetDescriptor::forward(const cv::Mat& working_image) const {
  const cv::Mat blob = cv::dnn::blobFromImage(working_image, 1.0 / 255.0);
  std::vector<cv::Mat> outputs;
  {
    MutexLock lock(net_mutex_);
    net_.setInput(blob);
    net_.forward(outputs,
                 std::vector<cv::String>{options_.proposal_layer, options_.descriptor_layer});
  }
  return {featureMapsFromBlob(outputs[0]), featureMapsFromBlob(outputs[1])};
}

ImageDescriptor ConvNetDescriptor::describe(const cv::Mat& image, DescribeStageTimes* times) const {
  DescribeStageTimes ignored;
  if (times == nullptr) times = &ignored;
  auto start = std::chrono::steady_clock::now();
  const auto lap = [&start](double* milliseconds) {
    const auto now = std::chrono::steady_clock::now();
    *milliseconds = std::chrono::duration<double, std::milli>(now - start).count();
    start = now;
  };
  const bool hog_features = options_.landmarks && options_.features == LandmarkFeatures::kHog;
  const cv::Mat working = hog_features ? toWorkingImage(image, options_.working_size.width,
                                                        options_.working_size.height)
                                       : toWorkingImage(image, kWidth, kHeight);
  cv::Mat network_input = working;
  if (working.cols != kWidth || working.rows != kHeight) {
    cv::resize(working, network_input, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_AREA);
  }
  lap(&times->prepare);
  const std::vector<FeatureMaps> maps = forward(network_input);
  ImageDescriptor descriptor;
  descriptor.global = maps[1].values;
  centreAndNormalise(&descriptor.global);
  lap(&times->network);
  if (!options_.landmarks) return descriptor;

  const cv::Size size(kWidth, kHeight);
  for (const LandmarkProposal& proposal : proposeLandmarks(maps[0], size, options_.proposals)) {
    descriptor.landmark_boxes.push_back(proposal.box);
  }
  lap(&times->proposals);
  if (hog_features) {
    descriptor.landmark_features =
        describeLandmarksByHog(working, size, descriptor.landmark_boxes, options_.hog_patch_side);
  } else if (options_.features == LandmarkFeatures::kConvMapCrop) {
    descriptor.landmark_features =
        describeLandmarks(maps[options_.crop_proposal_layer ? 0 : 1], size,
                          descriptor.landmark_boxes, options_.landmark_grid);
  } else {
    descriptor.landmark_features =
        describeLandmarksByNetwork(network_input, descriptor.landmark_boxes);
  }
  if (options_.float16_features) {
    descriptor.landmark_features.convertTo(descriptor.landmark_features, CV_16F);
  }
  lap(&times->landmark_features);
  return descriptor;
}

cv::Mat ConvNetDescriptor::describeLandmarksByNetwork(const cv::Mat& network_input,
                                                      const std::vector<cv::Rect2f>& boxes) const {
  const cv::Size size(kWidth, kHeight);
  // One pass per landmark: the crop resized to the network's input, its whole descriptor layer.
  cv::Mat features(static_cast<int>(boxes.size()), global_dimension_, CV_32F, cv::Scalar(0));
  for (size_t i = 0; i < boxes.size(); ++i) {
    const cv::Rect crop = cv::Rect(boxes[i]) & cv::Rect(0, 0, kWidth, kHeight);
    if (crop.area() == 0) continue;
    cv::Mat resized;
    cv::resize(network_input(crop), resized, size, 0, 0, cv::INTER_CUBIC);
    std::vector<float> values = forward(resized)[1].values;
    normaliseL2(&values);
    std::copy(values.begin(), values.end(), features.ptr<float>(static_cast<int>(i)));
  }
  return features;
}

double ConvNetDescriptor::similarity(const ImageDescriptor& query,
                                     const ImageDescriptor& candidate) const {
  if (!options_.landmarks) return cosineSimilarity(query.global, candidate.global);
  return landmarkSimilarity(query.landmark_boxes, query.landmark_features, candidate.landmark_boxes,
                            candidate.landmark_features, options_.weighting);
}

namespace {

std::shared_ptr<const DescriptorExtractor> makeConvNet(const DescriptorOptions& options) {
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

std::string modelIdentity(const DescriptorOptions& options) {
  return "model_fnv1a=" + fileHash(options.model.empty() ? defaultModelPath() : options.model);
}

// The variant name's parts: "landmarks_conv2_m30_paper", "landmarks_per_landmark",
// "landmarks_w480".
bool applyLandmarksVariantPart(const std::string& part, DescriptorOptions* options) {
  const auto number_after = [&part](size_t prefix) { return std::stoi(part.substr(prefix)); };
  const bool numbered = part.size() > 1 && std::isdigit(static_cast<unsigned char>(part.back()));
  if (part == "paper") {
    options->shape_weighting = "paper";
  } else if (part == "per") {
    options->landmark_features = "conv_per_landmark";
  } else if (part == "landmark") {
    return options->landmark_features == "conv_per_landmark";  // the end of "per_landmark"
  } else if (part == "conv2" || part == "conv3") {
    options->landmark_layer = part;
    options->landmark_features = "conv";
  } else if (part == "conv" || part == "hog") {
    options->landmark_features = part;
  } else if (part == "f32") {
    options->landmark_storage = "float32";
  } else if (!numbered) {
    return false;
  } else if (part.rfind("w", 0) == 0) {
    options->working_width = number_after(1);
    options->working_height = options->working_width * 3 / 4;
  } else if (part.rfind("patch", 0) == 0) {
    options->landmark_patch = number_after(5);
  } else if (part.rfind("area", 0) == 0) {
    options->max_landmark_area = number_after(4) / 100.0;
  } else if (part.rfind("grid", 0) == 0) {
    options->landmark_grid = number_after(4);
  } else if (part.rfind("m", 0) == 0) {
    options->max_landmarks = number_after(1);
  } else {
    return false;
  }
  return true;
}

}  // namespace

DescriptorType calcDescriptorType() {
  DescriptorType type;
  type.name = "calc";
  type.reads = {"model"};
  type.summary = "the package's CALC encoder's output alone, 1064 values";
  type.identity = modelIdentity;
  type.make = makeConvNet;
  return type;
}

DescriptorType landmarksDescriptorType() {
  DescriptorType type;
  type.name = "landmarks";
  type.reads = {"model",           "max_landmarks",     "landmark_grid",   "landmark_layer",
                "shape_weighting", "landmark_features", "working_width",   "working_height",
                "landmark_patch",  "max_landmark_area", "landmark_storage"};
  type.summary = "the encoder shortlists, landmark matching re-ranks (descriptor/* landmark keys)";
  type.identity = [](const DescriptorOptions& options) {
    std::ostringstream identity;
    identity << modelIdentity(options);
    identity << " max_landmarks=" << options.max_landmarks
             << " landmark_grid=" << options.landmark_grid
             << " landmark_layer=" << options.landmark_layer
             << " shape_weighting=" << options.shape_weighting
             << " landmark_features=" << options.landmark_features
             << " working=" << options.working_width << "x" << options.working_height
             << " landmark_patch=" << options.landmark_patch
             << " max_landmark_area=" << options.max_landmark_area
             << " landmark_storage=" << options.landmark_storage;
    return identity.str();
  };
  type.make = makeConvNet;
  type.apply_variant_part = applyLandmarksVariantPart;
  return type;
}

}  // namespace landmark_loop_closure
