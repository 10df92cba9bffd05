#include "landmark_loop_closure/cnn_global_descriptor.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {

std::string fileHash(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return "missing";
  uint64_t hash = 1469598103934665603ull;  // FNV-1a, 64 bit.
  char buffer[1 << 16];
  while (file.read(buffer, sizeof(buffer)) || file.gcount() > 0) {
    for (std::streamsize i = 0; i < file.gcount(); ++i) {
      hash = (hash ^ static_cast<unsigned char>(buffer[i])) * 1099511628211ull;
    }
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%llx", static_cast<unsigned long long>(hash));
  return text;
}

cv::dnn::Net loadOnnxNetwork(const std::string& path) {
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromONNX(path);
  } catch (const cv::Exception& error) {
    throw std::runtime_error("cannot load the ONNX model " + path + ": " + error.what());
  }
  if (net.empty()) throw std::runtime_error("cannot load the ONNX model " + path);
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  return net;
}

std::vector<double> parseNumberList(const std::string& text) {
  std::string spaced = text;
  for (char& c : spaced) {
    if (c == ',') c = ' ';
  }
  std::istringstream stream(spaced);
  std::vector<double> values;
  std::string word;
  while (stream >> word) {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0' || !std::isfinite(value)) {
      throw std::invalid_argument("'" + text + "' is not a list of numbers");
    }
    values.push_back(value);
  }
  return values;
}

cv::Mat networkInputBlob(const cv::Mat& image, cv::Size size, const std::string& colour,
                         const std::vector<double>& mean, const std::vector<double>& deviation) {
  cv::Mat converted;
  const bool grey_input = image.channels() == 1;
  if (colour == "grey") {
    if (grey_input) {
      converted = image;
    } else {
      cv::cvtColor(image, converted,
                   image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    }
  } else {
    const bool rgb = colour == "rgb";
    if (grey_input) {
      cv::cvtColor(image, converted, cv::COLOR_GRAY2BGR);  // Equal channels: order is moot.
    } else if (image.channels() == 4) {
      cv::cvtColor(image, converted, rgb ? cv::COLOR_BGRA2RGB : cv::COLOR_BGRA2BGR);
    } else if (rgb) {
      cv::cvtColor(image, converted, cv::COLOR_BGR2RGB);  // A new buffer: never the caller's.
    } else {
      converted = image;
    }
  }
  cv::Mat resized;
  const bool shrinking = converted.cols > size.width || converted.rows > size.height;
  cv::resize(converted, resized, size, 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_LINEAR);
  cv::Mat scaled;
  resized.convertTo(scaled, CV_32F, 1.0 / 255.0);
  std::vector<cv::Mat> planes;
  cv::split(scaled, planes);
  for (size_t c = 0; c < planes.size(); ++c) {
    planes[c] = (planes[c] - mean[c]) / deviation[c];
  }
  cv::merge(planes, scaled);
  return cv::dnn::blobFromImage(scaled);  // HWC -> 1xCxHxW, no further scaling.
}

namespace {

int channelCount(const std::string& colour) { return colour == "grey" ? 1 : 3; }

// The pooled vector of a 1xCxHxW or 1xC output.
Eigen::VectorXf pool(const cv::Mat& blob, FeaturePooling pooling) {
  if (blob.dims < 2 || blob.size[0] != 1 || blob.type() != CV_32F) {
    throw std::runtime_error("expected a 1xC or 1xCxHxW float output");
  }
  const int channels = blob.size[1];
  size_t per_channel = 1;
  for (int d = 2; d < blob.dims; ++d) per_channel *= static_cast<size_t>(blob.size[d]);
  const Eigen::Map<const Eigen::MatrixXf> maps(blob.ptr<float>(),
                                               static_cast<Eigen::Index>(per_channel), channels);
  switch (pooling) {
    case FeaturePooling::kAverage:
      return maps.colwise().mean().transpose();
    case FeaturePooling::kMax:
      return maps.colwise().maxCoeff().transpose();
    case FeaturePooling::kNone:
      break;
  }
  return Eigen::Map<const Eigen::VectorXf>(blob.ptr<float>(), maps.size());
}

void normalise(Eigen::VectorXf* vector) {
  const float norm = vector->norm();
  if (norm > 0.0f && std::isfinite(norm)) *vector /= norm;
}

}  // namespace

CnnGlobalDescriptor::CnnGlobalDescriptor(const CnnGlobalOptions& options) : options_(options) {
  const size_t channels = static_cast<size_t>(channelCount(options.colour));
  if (options.mean.size() != channels || options.std.size() != channels) {
    throw std::runtime_error("the network's mean and std need " + std::to_string(channels) +
                             " values each for colour '" + options.colour + "'");
  }
  for (const double s : options.std) {
    if (!(s > 0.0)) throw std::runtime_error("the network's std values must be > 0");
  }
  net_ = loadOnnxNetwork(options.model_path);

  std::ostringstream identity;
  identity << "model_fnv1a=" << fileHash(options.model_path) << " layer=" << options.layer
           << " input=" << options.input_size.width << "x" << options.input_size.height
           << " colour=" << options.colour << " mean=";
  for (const double m : options.mean) identity << m << ",";
  identity << " std=";
  for (const double s : options.std) identity << s << ",";
  identity << " pooling="
           << (options.pooling == FeaturePooling::kAverage ? "average"
               : options.pooling == FeaturePooling::kMax   ? "max"
                                                           : "none");
  feature_identity_ = identity.str();

  try {
    raw_dimension_ =
        static_cast<int>(rawFeature(cv::Mat(options.input_size, CV_8UC1, cv::Scalar(128))).size());
  } catch (const std::exception& error) {
    throw std::runtime_error("the ONNX model " + options.model_path + " gives no usable output '" +
                             options.layer + "' for a " + std::to_string(channels) + "x" +
                             std::to_string(options.input_size.height) + "x" +
                             std::to_string(options.input_size.width) + " input: " + error.what());
  }
  global_dimension_ = raw_dimension_;
  if (!options.whitening_path.empty()) {
    whitening_ = PcaWhitening::load(options.whitening_path, feature_identity_);
    if (whitening_.inputDimension() != raw_dimension_) {
      throw WhiteningFileError("whitening file " + options.whitening_path + " expects " +
                               std::to_string(whitening_.inputDimension()) +
                               " values, the layer gives " + std::to_string(raw_dimension_));
    }
    global_dimension_ = whitening_.outputDimension();
  }
}

Eigen::VectorXf CnnGlobalDescriptor::rawFeature(const cv::Mat& image) const {
  const cv::Mat blob =
      networkInputBlob(image, options_.input_size, options_.colour, options_.mean, options_.std);
  cv::Mat output;
  {
    std::lock_guard<std::mutex> lock(net_mutex_);
    net_.setInput(blob);
    output = net_.forward(options_.layer);
  }
  Eigen::VectorXf feature = pool(output, options_.pooling);
  normalise(&feature);
  return feature;
}

ImageDescriptor CnnGlobalDescriptor::describe(const cv::Mat& image) const {
  ImageDescriptor descriptor;
  if (image.empty() || image.depth() != CV_8U) return descriptor;
  Eigen::VectorXf feature = rawFeature(image);
  if (!whitening_.empty()) {
    feature = whitening_.apply(feature);
    normalise(&feature);
  }
  descriptor.global.assign(feature.data(), feature.data() + feature.size());
  return descriptor;
}

double CnnGlobalDescriptor::globalScore(double cosine) const {
  if (options_.similarity == GlobalSimilarity::kCosine) return cosine;
  // Unit vectors: D^2 = 2 - 2 cos, D <= 2.
  return 1.0 - std::sqrt(std::max(0.0, 2.0 - 2.0 * cosine)) / 2.0;
}

}  // namespace landmark_loop_closure
