#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/descriptors/model_description.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

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

std::string validateNetworkInput(const std::string& prefix, int width, int height,
                                 const std::string& colour, const std::string& mean,
                                 const std::string& deviation) {
  std::string errors;
  if (width < 8 || width > 4096 || height < 8 || height > 4096) {
    errors += prefix + "input_width and input_height must be in [8, 4096] (got " +
              std::to_string(width) + "x" + std::to_string(height) + ")\n";
  }
  if (colour != "rgb" && colour != "bgr" && colour != "grey") {
    errors += prefix + "colour must be one of 'rgb', 'bgr', 'grey' (got '" + colour + "')\n";
    return errors;
  }
  const size_t channels = colour == "grey" ? 1 : 3;
  for (const auto& [key, text] : {std::pair<const char*, const std::string&>{"mean", mean},
                                  std::pair<const char*, const std::string&>{"std", deviation}}) {
    std::vector<double> values;
    try {
      values = parseNumberList(text);
    } catch (const std::invalid_argument&) {
    }
    const bool positive = std::string(key) == "mean" ||
                          std::all_of(values.begin(), values.end(), [](double v) { return v > 0; });
    if (values.size() != channels || !positive) {
      errors += prefix + key + " must be " + std::to_string(channels) +
                (channels == 1 ? " number" : " numbers") +
                (std::string(key) == "std" ? " > 0" : "") + " for colour '" + colour + "' (got '" +
                text + "')\n";
    }
  }
  return errors;
}

cv::Mat networkInputBlob(const cv::Mat& image, cv::Size size, const std::string& colour,
                         const std::vector<double>& mean, const std::vector<double>& deviation) {
  // Resized first, colour-converted after: both act on each channel alone (resizing) or on each
  // pixel alone (channel order, grey to BGR), so the order changes nothing but the time - a
  // camera frame is many times the network's input. Grey from colour is the exception: it rounds
  // to 8 bits, so it stays first.
  const bool grey_input = image.channels() == 1;
  cv::Mat source;  // Never the caller's buffer as an output.
  if (colour == "grey" && !grey_input) {
    cv::cvtColor(image, source, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  } else {
    source = image;
  }
  cv::Mat resized;
  const bool shrinking = source.cols > size.width || source.rows > size.height;
  cv::resize(source, resized, size, 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_LINEAR);
  const bool rgb = colour == "rgb";
  const bool unit_scaled =
      std::all_of(mean.begin(), mean.end(), [](double m) { return m == 0.0; }) &&
      std::all_of(deviation.begin(), deviation.end(), [](double d) { return d == 1.0; });
  if (unit_scaled && colour != "grey" && resized.type() == CV_8UC3) {
    // Pixels in [0, 1] as they are (the shipped network): each 8-bit pixel goes straight into
    // its plane of the blob, scaled as convertTo scales it (one float multiplication), the
    // channel order swapped on the way: the floats of the passes below, in one pass.
    cv::Mat blob(std::vector<int>{1, 3, resized.rows, resized.cols}, CV_32F);
    const float scale = static_cast<float>(1.0 / 255.0);
    const int first = rgb ? 2 : 0;  // BGR pixels: the first plane of RGB is their third value.
    float* const plane0 = blob.ptr<float>(0, 0);
    float* const plane1 = blob.ptr<float>(0, 1);
    float* const plane2 = blob.ptr<float>(0, 2);
    for (int y = 0; y < resized.rows; ++y) {
      const uint8_t* pixel = resized.ptr<uint8_t>(y);
      const size_t row = static_cast<size_t>(y) * static_cast<size_t>(resized.cols);
      for (int x = 0; x < resized.cols; ++x, pixel += 3) {
        plane0[row + x] = static_cast<float>(pixel[first]) * scale;
        plane1[row + x] = static_cast<float>(pixel[1]) * scale;
        plane2[row + x] = static_cast<float>(pixel[2 - first]) * scale;
      }
    }
    return blob;
  }
  cv::Mat converted;  // Its own buffer: converting in place is not what cvtColor promises.
  if (colour == "grey" || (!grey_input && resized.channels() == 3 && !rgb)) {
    converted = resized;
  } else if (grey_input) {
    cv::cvtColor(resized, converted, cv::COLOR_GRAY2BGR);  // Equal channels: order is moot.
  } else if (resized.channels() == 4) {
    cv::cvtColor(resized, converted, rgb ? cv::COLOR_BGRA2RGB : cv::COLOR_BGRA2BGR);
  } else {
    cv::cvtColor(resized, converted, cv::COLOR_BGR2RGB);
  }
  cv::Mat scaled;
  converted.convertTo(scaled, CV_32F, 1.0 / 255.0);
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
    MutexLock lock(net_mutex_);
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

const ParameterTable<DescriptorOptions::Cnn>& DescriptorOptions::Cnn::parameters() {
  using O = DescriptorOptions::Cnn;
  static const auto table =
      ParameterTable<O>("advanced/descriptor/cnn/",
                        "type cnn_pca: a CNN layer pooled, PCA-whitened (methods.md section 2).")
          .text("model", &O::model,
                "ONNX file; \"\" = the package's encoder. README: a ResNet-50 instead.")
          .word("pooling", &O::pooling, {"average", "max", "none"},
                "layer -> vector: \"average\" or \"max\" per channel, \"none\" = all values.")
          .text("whitening", &O::whitening,
                "`lcd_train whitening` file; \"\" = the model's path + \".whitening\" when it "
                "exists, \"none\" = normalised layer without whitening.");
  return table;
}

const ParameterTable<DescriptorOptions::Cnn>& DescriptorOptions::Cnn::evaluationParameters() {
  using O = DescriptorOptions::Cnn;
  static const auto table =
      ParameterTable<O>("descriptor/cnn/", "")
          .word("similarity", &O::similarity, {"distance", "cosine"},
                "\"distance\": 1 - D/2, D the distance of the unit vectors (the paper's 1 - "
                "D/max(D)); \"cosine\". Both rank alike.");
  return table;
}

namespace {

std::string validateCnn(const DescriptorOptions& options) {
  const DescriptorOptions::Cnn& cnn = options.cnn;
  return DescriptorOptions::Cnn::parameters().check(cnn) +
         DescriptorOptions::Cnn::evaluationParameters().check(cnn) +
         validateNetworkInput(modelDescriptionPath(cnnModelPath(cnn)) + ": ", cnn.input_width,
                              cnn.input_height, cnn.colour, cnn.mean, cnn.std);
}

}  // namespace

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

DescriptorType cnnPcaDescriptorType() {
  DescriptorType type;
  type.name = "cnn_pca";
  type.reads = {"cnn/"};
  type.summary = "a CNN layer, pooled and PCA-whitened (advanced/descriptor/cnn/*)";
  type.validate = validateCnn;
  type.identity = [](const DescriptorOptions& options) {
    const DescriptorOptions::Cnn& cnn = options.cnn;
    const std::string whitening = whiteningPathFor(cnn);
    std::ostringstream identity;
    identity << "model_fnv1a=" << fileHash(cnnModelPath(cnn)) << " layer=" << cnn.layer
             << " input=" << cnn.input_width << "x" << cnn.input_height << " colour=" << cnn.colour
             << " mean=" << cnn.mean << " std=" << cnn.std << " pooling=" << cnn.pooling
             << " similarity=" << cnn.similarity
             << " whitening_fnv1a=" << (whitening.empty() ? "none" : fileHash(whitening));
    return identity.str();
  };
  type.make = [](const DescriptorOptions& options) {
    return std::make_shared<CnnGlobalDescriptor>(cnnGlobalOptions(options.cnn));
  };
  // cnn_pca_raw: without whitening; cnn_pca_cosine: cosine instead of 1 - D / 2.
  type.apply_variant_part = [](const std::string& part, DescriptorOptions* options) {
    if (part == "raw") {
      options->cnn.whitening = "none";
    } else if (part == "cosine") {
      options->cnn.similarity = "cosine";
    } else {
      return false;
    }
    return true;
  };
  return type;
}

}  // namespace landmark_loop_closure
