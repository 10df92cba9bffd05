#include "landmark_loop_closure/convnet_descriptor.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/hog_descriptor.h"

namespace landmark_loop_closure {

namespace {

FeatureMaps toFeatureMaps(const cv::Mat& blob) {
  if (blob.dims != 4 || blob.size[0] != 1) {
    throw std::runtime_error("expected a 1xCxHxW output from the network");
  }
  FeatureMaps maps;
  maps.channels = blob.size[1];
  maps.height = blob.size[2];
  maps.width = blob.size[3];
  const float* data = blob.ptr<float>();
  maps.values.assign(data, data + static_cast<size_t>(maps.channels) * maps.height * maps.width);
  return maps;
}

}  // namespace

ConvNetDescriptor::ConvNetDescriptor(const ConvNetOptions& options) : options_(options) {
  try {
    net_ = cv::dnn::readNetFromONNX(options.model_path);
  } catch (const cv::Exception& error) {
    throw std::runtime_error("cannot load the ONNX model " + options.model_path + ": " +
                             error.what());
  }
  if (net_.empty()) throw std::runtime_error("cannot load the ONNX model " + options.model_path);
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
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
    std::lock_guard<std::mutex> lock(net_mutex_);
    net_.setInput(blob);
    net_.forward(outputs,
                 std::vector<cv::String>{options_.proposal_layer, options_.descriptor_layer});
  }
  return {toFeatureMaps(outputs[0]), toFeatureMaps(outputs[1])};
}

ImageDescriptor ConvNetDescriptor::describe(const cv::Mat& image) const {
  const cv::Mat working = toWorkingImage(image, kWidth, kHeight);
  const std::vector<FeatureMaps> maps = forward(working);
  ImageDescriptor descriptor;
  descriptor.global = maps[1].values;
  centreAndNormalise(&descriptor.global);
  if (!options_.landmarks) return descriptor;

  const cv::Size size(kWidth, kHeight);
  for (const LandmarkProposal& proposal : proposeLandmarks(maps[0], size, options_.proposals)) {
    descriptor.landmark_boxes.push_back(proposal.box);
  }
  if (!options_.per_landmark_pass) {
    descriptor.landmark_features =
        describeLandmarks(maps[options_.crop_proposal_layer ? 0 : 1], size,
                          descriptor.landmark_boxes, options_.landmark_grid);
    return descriptor;
  }
  // One pass per landmark: the crop resized to the network's input, its whole descriptor layer.
  descriptor.landmark_features =
      cv::Mat(static_cast<int>(descriptor.landmark_boxes.size()), global_dimension_, CV_32F);
  for (size_t i = 0; i < descriptor.landmark_boxes.size(); ++i) {
    const cv::Rect crop = cv::Rect(descriptor.landmark_boxes[i]) & cv::Rect(0, 0, kWidth, kHeight);
    cv::Mat resized;
    cv::resize(working(crop), resized, size, 0, 0, cv::INTER_CUBIC);
    std::vector<float> values = forward(resized)[1].values;
    normaliseL2(&values);
    std::copy(values.begin(), values.end(),
              descriptor.landmark_features.ptr<float>(static_cast<int>(i)));
  }
  return descriptor;
}

double ConvNetDescriptor::similarity(const ImageDescriptor& query,
                                     const ImageDescriptor& candidate) const {
  if (!options_.landmarks) return cosineSimilarity(query.global, candidate.global);
  return landmarkSimilarity(query.landmark_boxes, query.landmark_features, candidate.landmark_boxes,
                            candidate.landmark_features, options_.weighting);
}

}  // namespace landmark_loop_closure
