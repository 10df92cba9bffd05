#include "landmark_loop_closure/descriptors/baseline_descriptors.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/descriptors/hog_descriptor.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

ImageDescriptor PixelDescriptor::describe(const cv::Mat& image) const {
  const cv::Mat grey = toWorkingImage(image, image.cols, image.rows);
  cv::Mat small;
  cv::resize(grey, small, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_AREA);
  ImageDescriptor descriptor;
  descriptor.global.assign(small.begin<uchar>(), small.end<uchar>());
  centreAndNormalise(&descriptor.global);
  return descriptor;
}

WholeImageHogDescriptor::WholeImageHogDescriptor()
    : hog_(cv::Size(HogDescriptor::kWidth, HogDescriptor::kHeight), cv::Size(16, 16),
           cv::Size(8, 8), cv::Size(8, 8), 9) {}

ImageDescriptor WholeImageHogDescriptor::describe(const cv::Mat& image) const {
  const cv::Mat working = toWorkingImage(image, HogDescriptor::kWidth, HogDescriptor::kHeight);
  ImageDescriptor descriptor;
  hog_.compute(working, descriptor.global);
  if (static_cast<int>(descriptor.global.size()) != kDimension) {
    throw std::logic_error("whole-image HOG produced " + std::to_string(descriptor.global.size()) +
                           " values, expected " + std::to_string(kDimension));
  }
  normaliseL2(&descriptor.global);
  return descriptor;
}

DescriptorType hogWholeDescriptorType() {
  DescriptorType type;
  type.name = "hog_whole";
  type.summary = "one 9-bin HOG window over the whole image, 9576 values";
  type.make = [](const DescriptorOptions&) { return std::make_shared<WholeImageHogDescriptor>(); };
  return type;
}

DescriptorType pixelsDescriptorType() {
  DescriptorType type;
  type.name = "pixels";
  type.summary = "the image shrunk to 32x24 grey pixels, 768 values";
  type.make = [](const DescriptorOptions&) { return std::make_shared<PixelDescriptor>(); };
  return type;
}

}  // namespace landmark_loop_closure
