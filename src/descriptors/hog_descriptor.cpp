#include "landmark_loop_closure/descriptors/hog_descriptor.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

namespace {
const cv::Size kWindow(16, 32);
const cv::Size kBlock(16, 16);
const cv::Size kBlockStride(16, 16);
const cv::Size kCell(8, 8);
constexpr int kBins = 2;
const cv::Size kWindowStride(8, 8);
}  // namespace

HogDescriptor::HogDescriptor() : hog_(kWindow, kBlock, kBlockStride, kCell, kBins) {}

ImageDescriptor HogDescriptor::describe(const cv::Mat& image) const {
  const cv::Mat working = toWorkingImage(image, kWidth, kHeight);
  ImageDescriptor descriptor;
  hog_.compute(working, descriptor.global, kWindowStride);
  if (static_cast<int>(descriptor.global.size()) != kDimension) {
    throw std::logic_error("HOG produced " + std::to_string(descriptor.global.size()) +
                           " values, expected " + std::to_string(kDimension));
  }
  centreAndNormalise(&descriptor.global);
  return descriptor;
}

DescriptorType hogDescriptorType() {
  DescriptorType type;
  type.name = "hog";
  type.summary = "HOG with CALC's settings: 160x120 grey, 3648 values";
  type.make = [](const DescriptorOptions&) { return std::make_shared<HogDescriptor>(); };
  return type;
}

}  // namespace landmark_loop_closure
