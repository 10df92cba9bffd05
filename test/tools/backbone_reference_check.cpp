// Compares the converted backbone (ONNX, run by OpenCV's dnn module as the node runs it) with the
// reference evaluation of the original model that backbone_reference.js wrote.
//   backbone_reference_check MODEL.onnx REFERENCE_DIR [tolerance]
// Passes when every output of every image agrees within `tolerance` (default 1e-3) relative:
// max |onnx - reference| <= tolerance * max |reference|.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/dnn.hpp>

namespace {

std::vector<float> readFloats(const std::string& path, size_t count) {
  std::vector<float> values(count);
  std::ifstream file(path, std::ios::binary);
  file.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(count * 4));
  if (!file || file.peek() != EOF)
    throw std::runtime_error(path + ": not " + std::to_string(count) + " floats");
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: backbone_reference_check MODEL.onnx REFERENCE_DIR [tolerance]\n";
    return 2;
  }
  const std::string dir = argv[2];
  const double tolerance = argc > 3 ? std::stod(argv[3]) : 1e-3;
  try {
    cv::dnn::Net net = cv::dnn::readNetFromONNX(argv[1]);
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    std::ifstream manifest(dir + "/manifest.txt");
    if (!manifest) throw std::runtime_error(dir + "/manifest.txt cannot be read");
    int compared = 0;
    bool all_close = true;
    std::string line;
    while (std::getline(manifest, line)) {
      std::istringstream fields(line);
      std::string image_file, layer, output_file;
      int height = 0, width = 0, out_h = 0, out_w = 0, out_c = 0;
      if (!(fields >> image_file >> height >> width >> layer >> output_file >> out_h >> out_w >>
            out_c))
        continue;
      const std::vector<float> nhwc =
          readFloats(dir + "/" + image_file, static_cast<size_t>(height) * width * 3);
      const int input_shape[] = {1, 3, height, width};
      cv::Mat input(4, input_shape, CV_32F);
      for (int c = 0; c < 3; ++c)
        for (int y = 0; y < height; ++y)
          for (int x = 0; x < width; ++x)
            input.ptr<float>(0, c)[y * width + x] =
                nhwc[(static_cast<size_t>(y) * width + x) * 3 + c];
      net.setInput(input, "image");
      const cv::Mat output = net.forward(layer);
      const std::vector<float> reference =
          readFloats(dir + "/" + output_file, static_cast<size_t>(out_h) * out_w * out_c);
      if (output.dims != 4 || output.size[1] != out_c || output.size[2] != out_h ||
          output.size[3] != out_w) {
        std::cerr << layer << " of " << image_file << ": shape differs from the reference " << out_h
                  << "x" << out_w << "x" << out_c << "\n";
        all_close = false;
        continue;
      }
      double max_reference = 0.0, max_difference = 0.0;
      for (int c = 0; c < out_c; ++c)
        for (int y = 0; y < out_h; ++y)
          for (int x = 0; x < out_w; ++x) {
            const double expected = reference[(static_cast<size_t>(y) * out_w + x) * out_c + c];
            const double actual = output.ptr<float>(0, c)[y * out_w + x];
            max_reference = std::max(max_reference, std::abs(expected));
            max_difference = std::max(max_difference, std::abs(actual - expected));
          }
      const double relative = max_difference / std::max(max_reference, 1e-12);
      const bool close = relative <= tolerance && std::isfinite(relative);
      std::printf("%-14s %-12s %3dx%-3d  max |diff| %.3g  max |ref| %.3g  relative %.2e  %s\n",
                  image_file.c_str(), layer.c_str(), width, height, max_difference, max_reference,
                  relative, close ? "ok" : "TOO FAR");
      all_close = all_close && close;
      ++compared;
    }
    if (compared == 0) throw std::runtime_error("no outputs listed in " + dir + "/manifest.txt");
    return all_close ? 0 : 1;
  } catch (const std::exception& error) {
    std::cerr << "backbone_reference_check: " << error.what() << "\n";
    return 1;
  }
}
