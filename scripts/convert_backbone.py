#!/usr/bin/python3
"""Converts a Keras layers model stored for TensorFlow.js (model JSON + weight shards) into ONNX
that OpenCV's dnn module runs, cut after the layers asked for.

usage: scripts/convert_backbone.py MODEL_JSON WEIGHTS_BIN OUTPUT_ONNX [--outputs a,b]

MODEL_JSON holds {"modelTopology": ..., "weightsManifest": ...} as tfjs writes it; WEIGHTS_BIN is
the manifest's shards concatenated. scripts/fetch_backbone.sh unwraps both from the nsfwjs
package. The graph takes a 1x3xHxW RGB image in [0, 1] named "image" (any H, W) and gives one
output per name in --outputs, named like the Keras layer.

Supported layers are those of MobileNetV2 as Keras 2.2.4 writes it: InputLayer, ZeroPadding2D,
Conv2D, DepthwiseConv2D, BatchNormalization, ReLU (max_value), Add. Weights quantised to uint8
with a per-tensor min and scale are dequantised (min + scale * q), as tfjs does.
"""

import argparse
import json
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 10  # Clip takes min/max as attributes up to opset 10, which OpenCV maps to ReLU6.


def read_weights(manifest, blob):
    """Name -> float32 array in Keras layout, from the manifest's concatenated shards."""
    weights = {}
    offset = 0
    for group in manifest:
        for spec in group["weights"]:
            shape = spec["shape"]
            count = int(np.prod(shape)) if shape else 1
            quantization = spec.get("quantization")
            if quantization:
                if quantization["dtype"] != "uint8":
                    raise ValueError(f"{spec['name']}: quantisation {quantization['dtype']} "
                                     "is not supported")
                raw = np.frombuffer(blob, dtype=np.uint8, count=count, offset=offset)
                values = quantization["min"] + quantization["scale"] * raw.astype(np.float64)
                offset += count
            else:
                if spec["dtype"] != "float32":
                    raise ValueError(f"{spec['name']}: dtype {spec['dtype']} is not supported")
                values = np.frombuffer(blob, dtype="<f4", count=count, offset=offset)
                offset += 4 * count
            weights[spec["name"]] = np.asarray(values, dtype=np.float32).reshape(shape)
    if offset != len(blob):
        raise ValueError(f"weights file holds {len(blob)} bytes, the manifest describes {offset}")
    return weights


def same_padding(kernel, strides, dilation):
    """TF 'same' padding as ONNX pads; only stride 1 is independent of the input size."""
    if any(s != 1 for s in strides):
        raise ValueError("'same' padding with stride > 1 depends on the input size; "
                         "only explicit ZeroPadding2D before strided layers is supported")
    pads_begin, pads_end = [], []
    for k, d in zip(kernel, dilation):
        total = (k - 1) * d
        pads_begin.append(total // 2)
        pads_end.append(total - total // 2)
    return pads_begin + pads_end


class Converter:
    def __init__(self, topology, weights):
        config = topology["model_config"]["config"]
        self.layers = {layer["name"]: layer for layer in config["layers"]}
        self.order = [layer["name"] for layer in config["layers"]]
        self.weights = weights
        self.used_weights = set()
        self.nodes = []
        self.initializers = []
        self.pending_pads = {}  # ZeroPadding2D name -> (its input tensor, ONNX pads)

    def weight(self, name):
        self.used_weights.add(name)
        return self.weights[name]

    def constant(self, name, array):
        self.initializers.append(numpy_helper.from_array(np.ascontiguousarray(array), name))
        return name

    def inputs_of(self, layer):
        nodes = layer["inbound_nodes"]
        if len(nodes) != 1:
            raise ValueError(f"{layer['name']}: shared layers are not supported")
        return [entry[0] for entry in nodes[0]]

    def tensor(self, layer_name):
        """The ONNX tensor a layer's output is; a pending ZeroPadding2D becomes an explicit Pad
        when something other than a valid convolution reads it."""
        if layer_name in self.pending_pads:
            source, pads = self.pending_pads.pop(layer_name)
            self.nodes.append(helper.make_node("Pad", [source], [layer_name], mode="constant",
                                               pads=[0, 0] + pads[:2] + [0, 0] + pads[2:]))
        return layer_name

    def convolution_pads(self, layer, source):
        """The pads of a convolution and the tensor it reads: an explicit ZeroPadding2D in front
        of a 'valid' convolution is folded into the convolution's own pads."""
        config = layer["config"]
        if config["padding"] == "same":
            return same_padding(config["kernel_size"], config["strides"],
                                config["dilation_rate"]), self.tensor(source)
        if source in self.pending_pads:
            padded_from, pads = self.pending_pads.pop(source)
            return pads, padded_from
        return [0, 0, 0, 0], self.tensor(source)

    def convert(self, outputs):
        needed = self.needed_layers(outputs)
        for name in self.order:
            if name not in needed:
                continue
            layer = self.layers[name]
            kind = layer["class_name"]
            config = layer["config"]
            if kind == "InputLayer":
                self.nodes.append(helper.make_node("Identity", ["image"], [name]))
                continue
            sources = self.inputs_of(layer)
            if kind == "ZeroPadding2D":
                (top, bottom), (left, right) = config["padding"]
                self.pending_pads[name] = (self.tensor(sources[0]), [top, left, bottom, right])
            elif kind in ("Conv2D", "DepthwiseConv2D"):
                self.convolution(layer, sources[0])
            elif kind == "BatchNormalization":
                if config.get("axis", -1) not in (-1, 3):
                    raise ValueError(f"{name}: batch normalisation over axis {config['axis']}")
                parameters = [self.constant(f"{name}/{part}", self.batch_norm_part(name, part))
                              for part in ("gamma", "beta", "moving_mean", "moving_variance")]
                self.nodes.append(helper.make_node(
                    "BatchNormalization", [self.tensor(sources[0])] + parameters, [name],
                    epsilon=float(config["epsilon"])))
            elif kind == "ReLU":
                if config.get("negative_slope", 0) != 0 or config.get("threshold", 0) != 0:
                    raise ValueError(f"{name}: only plain or capped ReLU is supported")
                if config.get("max_value") is None:
                    self.nodes.append(helper.make_node("Relu", [self.tensor(sources[0])], [name]))
                else:
                    self.nodes.append(helper.make_node("Clip", [self.tensor(sources[0])], [name],
                                                       min=0.0, max=float(config["max_value"])))
            elif kind == "Add":
                self.nodes.append(
                    helper.make_node("Add", [self.tensor(s) for s in sources], [name]))
            else:
                raise ValueError(f"{name}: layer type {kind} is not supported")
        for name in outputs:
            self.tensor(name)

    def batch_norm_part(self, layer_name, part):
        config = self.layers[layer_name]["config"]
        key = f"{layer_name}/{part}"
        if key in self.weights:
            return self.weight(key)
        # Keras leaves gamma / beta out when scale / center are off.
        size = len(self.weight(f"{layer_name}/moving_mean"))
        if part == "gamma" and not config.get("scale", True):
            return np.ones(size, np.float32)
        if part == "beta" and not config.get("center", True):
            return np.zeros(size, np.float32)
        raise KeyError(key)

    def convolution(self, layer, source):
        name = layer["name"]
        config = layer["config"]
        if config.get("activation", "linear") != "linear":
            raise ValueError(f"{name}: fused activation {config['activation']} is not supported")
        pads, input_tensor = self.convolution_pads(layer, source)
        if layer["class_name"] == "Conv2D":
            kernel = self.weight(f"{name}/kernel").transpose(3, 2, 0, 1)  # HWIO -> OIHW
            group = 1
        else:
            kernel = self.weight(f"{name}/depthwise_kernel")  # H W C multiplier
            height, width, channels, multiplier = kernel.shape
            kernel = kernel.transpose(2, 3, 0, 1).reshape(channels * multiplier, 1, height, width)
            group = channels
        inputs = [input_tensor, self.constant(f"{name}/weights", kernel)]
        if config.get("use_bias", False):
            inputs.append(self.constant(f"{name}/bias_", self.weight(f"{name}/bias")))
        self.nodes.append(helper.make_node(
            "Conv", inputs, [name], kernel_shape=list(kernel.shape[2:]),
            strides=list(config["strides"]), dilations=list(config["dilation_rate"]),
            pads=pads, group=group))

    def needed_layers(self, outputs):
        needed, stack = set(), list(outputs)
        while stack:
            name = stack.pop()
            if name in needed:
                continue
            if name not in self.layers:
                raise ValueError(f"no layer named {name}")
            needed.add(name)
            stack.extend(self.inputs_of(self.layers[name]) if self.layers[name]["inbound_nodes"]
                         else [])
        return needed

    def model(self, outputs, producer):
        graph = helper.make_graph(
            self.nodes, "backbone",
            [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, None, None])],
            [helper.make_tensor_value_info(name, TensorProto.FLOAT, [1, None, None, None])
             for name in outputs],
            self.initializers)
        model = helper.make_model(graph, producer_name=producer,
                                  opset_imports=[helper.make_opsetid("", OPSET)])
        onnx.checker.check_model(model)
        return model


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model_json")
    parser.add_argument("weights_bin")
    parser.add_argument("output_onnx")
    parser.add_argument("--outputs", default="block_5_add,block_12_add",
                        help="comma-separated Keras layer names the ONNX graph outputs")
    args = parser.parse_args()

    with open(args.model_json) as f:
        model_json = json.load(f)
    with open(args.weights_bin, "rb") as f:
        blob = f.read()
    weights = read_weights(model_json["weightsManifest"], blob)
    outputs = [name for name in args.outputs.split(",") if name]
    converter = Converter(model_json["modelTopology"], weights)
    converter.convert(outputs)
    model = converter.model(outputs, "landmark_loop_closure convert_backbone.py")
    onnx.save(model, args.output_onnx)
    print(f"convert_backbone: {args.output_onnx}: {len(converter.nodes)} nodes, "
          f"{len(converter.used_weights)} of {len(weights)} weight tensors, outputs "
          f"{', '.join(outputs)}")


if __name__ == "__main__":
    try:
        main()
    except (ValueError, KeyError, OSError) as error:
        sys.exit(f"convert_backbone: {error}")
