#include "landmark_loop_closure/descriptors/onednn_mobilenet.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <unordered_map>

#ifdef LANDMARK_LOOP_CLOSURE_HAVE_ONEDNN
#include <omp.h>

#include <dnnl.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn/all_layers.hpp>
#endif

namespace landmark_loop_closure {

#ifdef LANDMARK_LOOP_CLOSURE_HAVE_ONEDNN

namespace {

using dnnl::memory;
using Tag = memory::format_tag;
using Type = memory::data_type;

// One convolution with its folded batch normalisation, optional ReLU6 and residual addition.
struct Convolution {
  dnnl::convolution_forward primitive;
  memory weights;
  memory bias;
  int source = -1;    // Activation it reads.
  int residual = -1;  // Activation added to its output (-1: none).
  int output = -1;
};

// A reorder of one activation into another layout before convolution `before`.
struct Reorder {
  int from = -1;
  int to = -1;
  size_t before = 0;
};

// The ONNX importer names each layer after its node's output.
cv::Ptr<cv::dnn::Layer> findLayer(cv::dnn::Net& net, const std::string& keras_name) {
  const int id = net.getLayerId("onnx_node_output_0!" + keras_name);
  return id < 0 ? cv::Ptr<cv::dnn::Layer>() : net.getLayer(id);
}

}  // namespace

struct OneDnnMobileNet::Implementation {
  dnnl::engine engine{dnnl::engine::kind::cpu, 0};
  dnnl::stream stream{engine};
  std::vector<memory::desc> layouts;  // Of each activation; 0 is the plain input.
  std::vector<memory> activations;
  std::vector<Convolution> convolutions;
  std::vector<Reorder> reorders;
  std::vector<int> outputs;  // Activation of each requested output.
  std::vector<memory> plain_outputs;

  // Appends `name`'s convolution reading activation `source`; returns its output activation.
  int addConvolution(cv::dnn::Net& net, const std::string& name, const std::string& norm_name,
                     int source, int stride, bool padded_before, bool relu6, int residual) {
    const cv::Ptr<cv::dnn::Layer> convolution = findLayer(net, name);
    const cv::Ptr<cv::dnn::Layer> norm = findLayer(net, norm_name);
    if (!convolution || !norm || convolution->blobs.empty() || norm->blobs.size() != 4) {
      throw std::runtime_error("no convolution " + name + " with its batch normalisation");
    }
    const cv::Mat& kernel = convolution->blobs[0];
    if (kernel.dims != 4 || kernel.type() != CV_32F) {
      throw std::runtime_error(name + " has no 4-d float kernel");
    }
    const int out_channels = kernel.size[0];
    const int in_per_group = kernel.size[1];
    const int kernel_height = kernel.size[2];
    const int kernel_width = kernel.size[3];
    const memory::dims source_dims = layouts[source].dims();
    const int in_channels = static_cast<int>(source_dims[1]);
    if (in_channels % in_per_group != 0) throw std::runtime_error(name + ": channels disagree");
    const int groups = in_channels / in_per_group;
    // OpenCV keeps a batch normalisation's mean, variance, scale and shift, in that order.
    const auto* norm_layer = dynamic_cast<const cv::dnn::BatchNormLayer*>(norm.get());
    const float epsilon = norm_layer ? norm_layer->epsilon : 1e-3f;
    const float* mean = norm->blobs[0].ptr<float>();
    const float* variance = norm->blobs[1].ptr<float>();
    const float* gamma = norm->blobs[2].ptr<float>();
    const float* beta = norm->blobs[3].ptr<float>();
    std::vector<float> weights(kernel.total());
    std::vector<float> bias(static_cast<size_t>(out_channels));
    const size_t per_output = kernel.total() / static_cast<size_t>(out_channels);
    const float* raw = kernel.ptr<float>();
    for (int o = 0; o < out_channels; ++o) {
      const float scale = gamma[o] / std::sqrt(variance[o] + epsilon);
      for (size_t k = 0; k < per_output; ++k) {
        weights[o * per_output + k] = raw[o * per_output + k] * scale;
      }
      const float own_bias = convolution->blobs.size() > 1 ? convolution->blobs[1].at<float>(o) : 0;
      bias[static_cast<size_t>(o)] = (own_bias - mean[o]) * scale + beta[o];
    }
    // Keras pads (0, 1) before each strided convolution, 'same' (k - 1) / 2 elsewhere.
    const int pad_before = padded_before ? 0 : (kernel_height - 1) / 2;
    const int pad_after = padded_before ? 1 : (kernel_height - 1) / 2;
    const int out_height =
        (static_cast<int>(source_dims[2]) + pad_before + pad_after - kernel_height) / stride + 1;
    const int out_width =
        (static_cast<int>(source_dims[3]) + pad_before + pad_after - kernel_width) / stride + 1;
    const memory::dims weight_dims =
        groups > 1
            ? memory::dims{groups, out_channels / groups, in_per_group, kernel_height, kernel_width}
            : memory::dims{out_channels, in_channels, kernel_height, kernel_width};
    const memory::desc bias_layout({out_channels}, Type::f32, Tag::x);
    const dnnl::convolution_forward::desc description(
        dnnl::prop_kind::forward_inference, dnnl::algorithm::convolution_direct,
        memory::desc(source_dims, Type::f32, Tag::any),
        memory::desc(weight_dims, Type::f32, Tag::any), bias_layout,
        memory::desc({1, out_channels, out_height, out_width}, Type::f32, Tag::any),
        {stride, stride}, {pad_before, pad_before}, {pad_after, pad_after});
    dnnl::post_ops operations;
    if (relu6) operations.append_eltwise(1.f, dnnl::algorithm::eltwise_clip, 0.f, 6.f);
    // The residual is copied into the output first; the sum post-op adds the convolution to it.
    if (residual >= 0) operations.append_sum(1.f);
    dnnl::primitive_attr attributes;
    attributes.set_post_ops(operations);
    const dnnl::convolution_forward::primitive_desc chosen(description, attributes, engine);

    Convolution step;
    step.primitive = dnnl::convolution_forward(chosen);
    memory plain_weights({weight_dims, Type::f32, groups > 1 ? Tag::goihw : Tag::oihw}, engine,
                         weights.data());
    step.weights = memory(chosen.weights_desc(), engine);
    dnnl::reorder(plain_weights, step.weights).execute(stream, plain_weights, step.weights);
    step.bias = memory(bias_layout, engine);
    std::memcpy(step.bias.get_data_handle(), bias.data(), bias.size() * sizeof(float));
    stream.wait();
    if (chosen.src_desc() != layouts[static_cast<size_t>(source)]) {
      layouts.push_back(chosen.src_desc());
      reorders.push_back({source, static_cast<int>(layouts.size()) - 1, convolutions.size()});
      source = static_cast<int>(layouts.size()) - 1;
    }
    step.source = source;
    step.residual = residual;
    layouts.push_back(chosen.dst_desc());
    step.output = static_cast<int>(layouts.size()) - 1;
    convolutions.push_back(step);
    return step.output;
  }

  // Builds the network up to the last requested output; throws what it cannot build.
  void build(cv::dnn::Net& net, cv::Size input, const std::vector<std::string>& wanted) {
    if (!findLayer(net, "Conv1") || !findLayer(net, "expanded_conv_project")) {
      throw std::runtime_error("it is not a Keras MobileNetV2 (no Conv1, expanded_conv_project)");
    }
    layouts.push_back(memory::desc({1, 3, input.height, input.width}, Type::f32, Tag::nchw));
    std::map<std::string, int> named;
    int current = addConvolution(net, "Conv1", "bn_Conv1", 0, 2, true, true, -1);
    named["Conv1_relu"] = current;
    current = addConvolution(net, "expanded_conv_depthwise", "expanded_conv_depthwise_BN", current,
                             1, false, true, -1);
    current = addConvolution(net, "expanded_conv_project", "expanded_conv_project_BN", current, 1,
                             false, false, -1);
    named["expanded_conv_project_BN"] = current;
    const auto all_found = [&] {
      for (const std::string& name : wanted) {
        if (named.count(name) == 0) return false;
      }
      return true;
    };
    for (int block = 1; !all_found(); ++block) {
      const std::string prefix = "block_" + std::to_string(block);
      if (!findLayer(net, prefix + "_expand")) {
        throw std::runtime_error("the network has no layer named like the output asked for");
      }
      const int block_input = current;
      const bool strided = static_cast<bool>(findLayer(net, prefix + "_depthwise/pad"));
      current = addConvolution(net, prefix + "_expand", prefix + "_expand_BN", current, 1, false,
                               true, -1);
      named[prefix + "_expand_relu"] = current;
      current = addConvolution(net, prefix + "_depthwise", prefix + "_depthwise_BN", current,
                               strided ? 2 : 1, strided, true, -1);
      named[prefix + "_depthwise_relu"] = current;
      const bool adds = static_cast<bool>(findLayer(net, prefix + "_add"));
      current = addConvolution(net, prefix + "_project", prefix + "_project_BN", current, 1, false,
                               false, adds ? block_input : -1);
      named[adds ? prefix + "_add" : prefix + "_project_BN"] = current;
    }
    for (const memory::desc& layout : layouts) activations.emplace_back(layout, engine);
    for (const std::string& name : wanted) {
      const int activation = named.at(name);
      outputs.push_back(activation);
      plain_outputs.emplace_back(
          memory::desc(layouts[static_cast<size_t>(activation)].dims(), Type::f32, Tag::nchw),
          engine);
    }
  }

  std::vector<cv::Mat> forward(const cv::Mat& blob) {
    const memory::desc& input = layouts.front();
    if (!blob.isContinuous() || blob.type() != CV_32F ||
        blob.total() * sizeof(float) != input.get_size()) {
      throw std::invalid_argument("the network's input blob has another size or type");
    }
    // The node's worker, like OpenCV's dnn, uses OpenCV's thread count.
    omp_set_num_threads(std::max(1, cv::getNumThreads()));
    std::memcpy(activations.front().get_data_handle(), blob.ptr<float>(), input.get_size());
    size_t next_reorder = 0;
    for (size_t i = 0; i < convolutions.size(); ++i) {
      for (; next_reorder < reorders.size() && reorders[next_reorder].before == i; ++next_reorder) {
        memory& from = activations[static_cast<size_t>(reorders[next_reorder].from)];
        memory& to = activations[static_cast<size_t>(reorders[next_reorder].to)];
        dnnl::reorder(from, to).execute(stream, from, to);
      }
      Convolution& step = convolutions[i];
      memory& output = activations[static_cast<size_t>(step.output)];
      if (step.residual >= 0) {
        memory& residual = activations[static_cast<size_t>(step.residual)];
        dnnl::reorder(residual, output).execute(stream, residual, output);
      }
      step.primitive.execute(stream, {{DNNL_ARG_SRC, activations[static_cast<size_t>(step.source)]},
                                      {DNNL_ARG_WEIGHTS, step.weights},
                                      {DNNL_ARG_BIAS, step.bias},
                                      {DNNL_ARG_DST, output}});
    }
    std::vector<cv::Mat> results;
    for (size_t k = 0; k < outputs.size(); ++k) {
      memory& activation = activations[static_cast<size_t>(outputs[k])];
      dnnl::reorder(activation, plain_outputs[k]).execute(stream, activation, plain_outputs[k]);
    }
    stream.wait();
    for (size_t k = 0; k < outputs.size(); ++k) {
      const memory::dims dims = plain_outputs[k].get_desc().dims();
      const int shape[] = {1, static_cast<int>(dims[1]), static_cast<int>(dims[2]),
                           static_cast<int>(dims[3])};
      results.push_back(cv::Mat(4, shape, CV_32F, plain_outputs[k].get_data_handle()).clone());
    }
    return results;
  }
};

bool OneDnnMobileNet::available() { return true; }

std::unique_ptr<OneDnnMobileNet> OneDnnMobileNet::create(cv::dnn::Net& net, cv::Size input,
                                                         const std::vector<std::string>& outputs,
                                                         std::string* why) {
  auto implementation = std::make_unique<Implementation>();
  // oneDNN fixes a primitive's threads when it is created: OpenCV's thread count from the start.
  omp_set_num_threads(std::max(1, cv::getNumThreads()));
  try {
    implementation->build(net, input, outputs);
  } catch (const std::exception& error) {
    if (why) *why = error.what();
    return nullptr;
  }
  std::unique_ptr<OneDnnMobileNet> network(new OneDnnMobileNet(std::move(implementation)));
  // Checked against OpenCV's dnn on a fixed pattern before it takes over.
  const int shape[] = {1, 3, input.height, input.width};
  cv::Mat pattern(4, shape, CV_32F);
  float* values = pattern.ptr<float>();
  for (size_t i = 0; i < pattern.total(); ++i) {
    values[i] = static_cast<float>((i * 7919 % 1000) / 1000.0);
  }
  std::vector<cv::Mat> expected;
  net.setInput(pattern);
  net.forward(expected, std::vector<cv::String>(outputs.begin(), outputs.end()));
  const std::vector<cv::Mat> got = network->forward(pattern);
  for (size_t k = 0; k < outputs.size(); ++k) {
    const double scale = std::max(1e-6, cv::norm(expected[k], cv::NORM_INF));
    const double difference =
        expected[k].total() == got[k].total()
            ? cv::norm(expected[k].reshape(1, 1), got[k].reshape(1, 1), cv::NORM_INF)
            : scale;
    if (difference > 1e-3 * scale) {
      if (why) *why = "its " + outputs[k] + " differs from OpenCV's dnn";
      return nullptr;
    }
  }
  return network;
}

#else  // Built without oneDNN.

struct OneDnnMobileNet::Implementation {
  std::vector<cv::Mat> forward(const cv::Mat&) { return {}; }
};

bool OneDnnMobileNet::available() { return false; }

std::unique_ptr<OneDnnMobileNet> OneDnnMobileNet::create(cv::dnn::Net&, cv::Size,
                                                         const std::vector<std::string>&,
                                                         std::string* why) {
  if (why) *why = "this build has no oneDNN (Debian's libdnnl-dev)";
  return nullptr;
}

#endif

OneDnnMobileNet::OneDnnMobileNet(std::unique_ptr<Implementation> implementation)
    : implementation_(std::move(implementation)) {}

OneDnnMobileNet::~OneDnnMobileNet() = default;

std::vector<cv::Mat> OneDnnMobileNet::forward(const cv::Mat& blob) {
  return implementation_->forward(blob);
}

}  // namespace landmark_loop_closure
