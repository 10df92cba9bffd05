#!/usr/bin/python3
"""The backbone's network pass in libtorch (Debian's python3-torch, the same libtorch 1.13 as
libtorch-dev), one thread, on the input lcd_bench_network wrote, compared with OpenCV dnn's
output for it: time per pass (median, p99) for eager, TorchScript and frozen +
optimize_for_inference (oneDNN), and the outputs' agreement.

usage (needs python3-torch and python3-onnx; bench/history.md "Another engine for the network"):
  lcd_bench_network --write-input in.f32 --write-output out.f32
  bench/engine_libtorch.py model/mobilenet_v2.onnx in.f32 out.f32 [--layer block_12_add]
      [--width 256] [--height 144]

The ONNX graph (Conv, BatchNormalization, Clip, Add, Identity: what scripts/convert_backbone.py
writes) is rebuilt as torch modules with each batch normalisation folded into its convolution,
as OpenCV's dnn folds it.
"""
import argparse
import time

import numpy as np
import onnx
import torch
import torch.nn.functional as F
from onnx import numpy_helper


def attributes(node):
    return {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}


def plan_of(model):
    """The graph as steps; a BatchNormalization right after a Conv is folded into it."""
    weights = {t.name: torch.from_numpy(numpy_helper.to_array(t).copy())
               for t in model.graph.initializer}
    nodes = list(model.graph.node)
    steps = []
    i = 0
    while i < len(nodes):
        node = nodes[i]
        if node.op_type == "Conv":
            a = attributes(node)
            weight = weights[node.input[1]].clone()
            bias = (weights[node.input[2]].clone() if len(node.input) > 2
                    else torch.zeros(weight.shape[0]))
            output = node.output[0]
            following = nodes[i + 1] if i + 1 < len(nodes) else None
            if (following is not None and following.op_type == "BatchNormalization"
                    and following.input[0] == output):
                gamma, beta, mean, variance = (weights[x] for x in following.input[1:5])
                scale = gamma / torch.sqrt(variance + attributes(following)["epsilon"])
                weight = weight * scale.reshape(-1, 1, 1, 1)
                bias = (bias - mean) * scale + beta
                output = following.output[0]
                i += 1
            top, left, bottom, right = a["pads"]
            steps.append(("conv", node.input[0], output, weight, bias, a["strides"], a["group"],
                          (left, right, top, bottom)))
        elif node.op_type == "Clip":
            a = attributes(node)
            steps.append(("clip", node.input[0], node.output[0], a["min"], a["max"]))
        elif node.op_type == "Add":
            steps.append(("add", node.input[0], node.output[0], node.input[1]))
        elif node.op_type == "Identity":
            steps.append(("identity", node.input[0], node.output[0]))
        else:
            raise SystemExit(f"engine_libtorch: unsupported operation {node.op_type}")
        i += 1
    return steps


class Network(torch.nn.Module):
    def __init__(self, steps, layer):
        super().__init__()
        self.layer = layer
        self.convolutions = torch.nn.ModuleList()
        self.plan = []
        for step in steps:
            if step[0] != "conv":
                self.plan.append(step)
                continue
            _, source, target, weight, bias, stride, group, pad = step
            convolution = torch.nn.Conv2d(weight.shape[1] * group, weight.shape[0],
                                          tuple(weight.shape[2:]), stride=tuple(stride),
                                          groups=group, bias=True)
            convolution.weight.data.copy_(weight)
            convolution.bias.data.copy_(bias)
            symmetric = len(set(pad)) == 1
            if symmetric:
                convolution.padding = (pad[0], pad[0])
            self.convolutions.append(convolution)
            self.plan.append(("conv", source, target, len(self.convolutions) - 1,
                              None if symmetric else pad))

    def forward(self, image):
        values = {"image": image}
        for step in self.plan:
            if step[0] == "conv":
                x = values[step[1]]
                if step[4] is not None:
                    x = F.pad(x, step[4])  # Keras' asymmetric 'same' padding before strides.
                values[step[2]] = self.convolutions[step[3]](x)
            elif step[0] == "clip":
                values[step[2]] = torch.clamp(values[step[1]], step[3], step[4])
            elif step[0] == "add":
                values[step[2]] = values[step[1]] + values[step[3]]
            else:
                values[step[2]] = values[step[1]]
        return values[self.layer]


def measure(name, run, image, reference, repeat=200):
    with torch.no_grad():
        for _ in range(20):  # Warm-up, as lcd_bench_network does.
            output = run(image)
        times = []
        for _ in range(repeat):
            start = time.perf_counter()
            output = run(image)
            times.append((time.perf_counter() - start) * 1e3)
    values = output.contiguous().numpy().ravel()
    cosine = float(values @ reference / np.linalg.norm(values) / np.linalg.norm(reference))
    times.sort()
    median = times[(repeat + 1) // 2 - 1]
    p99 = times[int(np.ceil(0.99 * repeat)) - 1]
    print(f"{name}: median {median:.2f} ms, p99 {p99:.2f} ms, cosine to OpenCV's output "
          f"{cosine:.6f}, largest difference {np.abs(values - reference).max():.1e}")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("model")
    parser.add_argument("input")
    parser.add_argument("opencv_output")
    parser.add_argument("--layer", default="block_12_add")
    parser.add_argument("--width", type=int, default=256)
    parser.add_argument("--height", type=int, default=144)
    arguments = parser.parse_args()
    torch.set_num_threads(1)
    network = Network(plan_of(onnx.load(arguments.model)), arguments.layer).eval()
    image = torch.from_numpy(np.fromfile(arguments.input, dtype=np.float32)
                             .reshape(1, 3, arguments.height, arguments.width))
    reference = np.fromfile(arguments.opencv_output, dtype=np.float32)
    print(f"libtorch {torch.__version__} (oneDNN {torch.backends.mkldnn.is_available()}), "
          f"one thread, {arguments.layer} at {arguments.width}x{arguments.height}")
    with torch.no_grad():
        traced = torch.jit.trace(network, image)
        frozen = torch.jit.optimize_for_inference(torch.jit.freeze(traced))
    measure("eager", network, image, reference)
    measure("TorchScript", traced, image, reference)
    measure("frozen + optimize_for_inference", frozen, image, reference)


if __name__ == "__main__":
    main()
