#pragma once

// A descriptor for tests: each image's top-left pixel holds its "place"; descriptors are one-hot in
// that value, so two images match exactly when they show the same place. The rest is striped so
// that the image has texture (uniform images are refused as input).

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {
namespace test_support {

class PlaceExtractor : public DescriptorExtractor {
 public:
  std::string name() const override { return "place"; }
  int globalDimension() const override { return 256; }
  ImageDescriptor describe(const cv::Mat& image) const override {
    ImageDescriptor descriptor;
    descriptor.global.assign(256, 0.0f);
    descriptor.global[image.at<uchar>(0, 0)] = 1.0f;
    return descriptor;
  }
};

inline cv::Mat place(int value, cv::Size size = cv::Size(64, 48)) {
  cv::Mat image(size, CV_8UC1, cv::Scalar(value));
  for (int row = 1; row < size.height; row += 2) image.row(row).setTo((value + 128) % 256);
  return image;
}

}  // namespace test_support
}  // namespace landmark_loop_closure
