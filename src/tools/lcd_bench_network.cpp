// The backbone's network pass alone on one thread: OpenCV's dnn, and oneDNN where this build has
// it (descriptors/onednn_mobilenet.h), time per pass (median, p99) on a fixed input and the
// largest difference between their outputs; the input and OpenCV's output written as raw
// float32, so that another engine (bench/engine_libtorch.py) is compared on the same numbers.
//   lcd_bench_network [--model FILE] [--layer block_12_add] [--width 256] [--height 144]
//                     [--repeat 200] [--write-input FILE] [--write-output FILE]
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "command_line.h"
#include "landmark_loop_closure/common/durable_file.h"
#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/onednn_mobilenet.h"
#include "landmark_loop_closure/eval/metrics.h"

namespace {

using namespace landmark_loop_closure;

bool writeFloats(const std::string& path, const cv::Mat& values) {
  const std::string failed =
      writeFileDurably(path, values.ptr<float>(), values.total() * sizeof(float));
  if (!failed.empty()) std::fprintf(stderr, "lcd_bench_network: %s\n", failed.c_str());
  return failed.empty();
}

}  // namespace

int main(int argc, char** argv) {
  std::string model = backboneModelPath(DescriptorOptions::Backbone()), layer = "block_12_add";
  std::string write_input, write_output;
  int width = 256, height = 144, repeat = 200;
  CLI::App app{"The network pass alone, OpenCV's dnn against oneDNN, on one thread."};
  app.add_option("--model", model, "ONNX file")->capture_default_str();
  app.add_option("--layer", layer, "output layer")->capture_default_str();
  app.add_option("--width", width, "input width")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--height", height, "input height")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--repeat", repeat, "timed passes (after 20 to warm up)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--write-input", write_input, "file for the input tensor (raw floats)");
  app.add_option("--write-output", write_output, "file for OpenCV's output (raw floats)");
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  cv::setNumThreads(1);
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromONNX(model);
  } catch (const cv::Exception& error) {
    std::fprintf(stderr, "lcd_bench_network: cannot read %s (%s)\n", model.c_str(), error.what());
    return 1;
  }
  const int shape[] = {1, 3, height, width};
  cv::Mat input(4, shape, CV_32F);
  // A fixed pattern in [0, 1), the same on every machine: the network's input range.
  float* values = input.ptr<float>();
  for (size_t i = 0; i < input.total(); ++i) {
    values[i] = static_cast<float>((i * 7919 % 1000) / 1000.0);
  }
  // Built from its own parse, before OpenCV's first pass rewrites the weights it fuses.
  cv::dnn::Net fast_source = cv::dnn::readNetFromONNX(model);
  std::string why;
  std::unique_ptr<OneDnnMobileNet> fast =
      OneDnnMobileNet::create(fast_source, cv::Size(shape[3], shape[2]), {layer}, &why);
  const auto timed = [&](const std::function<cv::Mat()>& pass, cv::Mat* output) {
    std::vector<double> times;
    for (int r = 0; r < repeat + 20; ++r) {  // The first 20 warm up (allocation, caches).
      const Clock::time_point start = Clock::now();
      *output = pass();
      if (r >= 20) times.push_back(millisecondsSince(start));
    }
    return eval::percentiles(times);
  };
  cv::Mat output;
  const eval::Percentiles time = timed(
      [&] {
        net.setInput(input);
        return net.forward(layer);
      },
      &output);
  std::printf("%s to %s at %dx%d, one thread, %d passes\n", model.c_str(), layer.c_str(), shape[3],
              shape[2], repeat);
  std::printf("  OpenCV %s dnn: median %.2f ms, p99 %.2f ms\n", CV_VERSION, time.median, time.p99);
  if (fast) {
    cv::Mat fast_output;
    const eval::Percentiles fast_time =
        timed([&] { return fast->forward(input).front(); }, &fast_output);
    std::printf(
        "  oneDNN: median %.2f ms, p99 %.2f ms (%.2fx), largest difference to OpenCV's "
        "output %.1e (its largest value %.1f)\n",
        fast_time.median, fast_time.p99, time.median / fast_time.median,
        cv::norm(fast_output.reshape(1, 1), output.reshape(1, 1), cv::NORM_INF),
        cv::norm(output, cv::NORM_INF));
  } else {
    std::printf("  oneDNN: not run (%s)\n", why.c_str());
  }
  if (!write_input.empty() && !writeFloats(write_input, input)) {
    std::fprintf(stderr, "lcd_bench_network: cannot write %s\n", write_input.c_str());
    return 1;
  }
  if (!write_output.empty() && !writeFloats(write_output, output)) {
    std::fprintf(stderr, "lcd_bench_network: cannot write %s\n", write_output.c_str());
    return 1;
  }
  return 0;
}
