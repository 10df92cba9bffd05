#pragma once

// Writes a tiny ONNX network with known weights, so tests can check what a descriptor computes
// from a network's output without shipping a model: input "input" (1 x channels x H x W),
// a 1x1 convolution with the given weights and biases, ReLU (output "features"), global average
// pooling (output "pooled", 1 x outputs x 1 x 1). The protobuf encoding is written by hand.

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace landmark_loop_closure {
namespace test {

class ProtoWriter {
 public:
  void varintField(int field, uint64_t value) {
    key(field, 0);
    varint(value);
  }
  void bytesField(int field, const std::string& value) {
    key(field, 2);
    varint(value.size());
    bytes_ += value;
  }
  void floatField(int field, float value) {
    key(field, 5);
    char raw[4];
    std::memcpy(raw, &value, 4);  // Tests run on little-endian hosts, as ONNX stores floats.
    bytes_.append(raw, 4);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  void key(int field, int wire_type) { varint(static_cast<uint64_t>(field) << 3 | wire_type); }
  void varint(uint64_t value) {
    while (value >= 0x80) {
      bytes_.push_back(static_cast<char>((value & 0x7f) | 0x80));
      value >>= 7;
    }
    bytes_.push_back(static_cast<char>(value));
  }
  std::string bytes_;
};

inline std::string floatTensor(const std::string& name, const std::vector<int64_t>& dims,
                               const std::vector<float>& values) {
  ProtoWriter tensor;
  for (const int64_t d : dims) tensor.varintField(1, static_cast<uint64_t>(d));
  tensor.varintField(2, 1);  // FLOAT
  tensor.bytesField(8, name);
  tensor.bytesField(
      9, std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float)));
  return tensor.bytes();
}

inline std::string valueInfo(const std::string& name, const std::vector<int64_t>& dims) {
  ProtoWriter shape;
  for (const int64_t d : dims) {
    ProtoWriter dimension;
    dimension.varintField(1, static_cast<uint64_t>(d));
    shape.bytesField(1, dimension.bytes());
  }
  ProtoWriter tensor_type;
  tensor_type.varintField(1, 1);  // FLOAT
  tensor_type.bytesField(2, shape.bytes());
  ProtoWriter type;
  type.bytesField(1, tensor_type.bytes());
  ProtoWriter info;
  info.bytesField(1, name);
  info.bytesField(2, type.bytes());
  return info.bytes();
}

inline std::string intsAttribute(const std::string& name, const std::vector<int64_t>& values) {
  ProtoWriter attribute;
  attribute.bytesField(1, name);
  for (const int64_t v : values) attribute.varintField(8, static_cast<uint64_t>(v));
  attribute.varintField(20, 7);  // INTS
  return attribute.bytes();
}

inline std::string node(const std::string& op, const std::vector<std::string>& inputs,
                        const std::string& output, const std::vector<std::string>& attributes) {
  ProtoWriter proto;
  for (const std::string& input : inputs) proto.bytesField(1, input);
  proto.bytesField(2, output);
  proto.bytesField(3, output + "_node");
  proto.bytesField(4, op);
  for (const std::string& attribute : attributes) proto.bytesField(5, attribute);
  return proto.bytes();
}

/// weights: outputs x channels (row-major), biases: outputs.
inline void writeOneByOneConvNet(const std::string& path, int channels, int height, int width,
                                 const std::vector<float>& weights,
                                 const std::vector<float>& biases) {
  const int64_t outputs = static_cast<int64_t>(biases.size());
  ProtoWriter graph;
  graph.bytesField(1, node("Conv", {"input", "weight", "bias"}, "conv",
                           {intsAttribute("kernel_shape", {1, 1}), intsAttribute("strides", {1, 1}),
                            intsAttribute("pads", {0, 0, 0, 0})}));
  graph.bytesField(1, node("Relu", {"conv"}, "features", {}));
  graph.bytesField(1, node("GlobalAveragePool", {"features"}, "pooled", {}));
  graph.bytesField(2, "test_net");
  graph.bytesField(5, floatTensor("weight", {outputs, channels, 1, 1}, weights));
  graph.bytesField(5, floatTensor("bias", {outputs}, biases));
  graph.bytesField(11, valueInfo("input", {1, channels, height, width}));
  graph.bytesField(12, valueInfo("pooled", {1, outputs, 1, 1}));
  graph.bytesField(12, valueInfo("features", {1, outputs, height, width}));

  ProtoWriter opset;
  opset.bytesField(1, "");
  opset.varintField(2, 11);
  ProtoWriter model;
  model.varintField(1, 6);  // IR version
  model.bytesField(2, "landmark_loop_closure tests");
  model.bytesField(7, graph.bytes());
  model.bytesField(8, opset.bytes());
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << model.bytes();
}

}  // namespace test
}  // namespace landmark_loop_closure
