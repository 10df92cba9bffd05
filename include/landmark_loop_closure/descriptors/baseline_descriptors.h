#pragma once

#include <opencv2/objdetect.hpp>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// Baseline: the image shrunk to 32x24 grey pixels (area averaging), centred and L2-normalised:
/// 768 values. The simplest appearance descriptor; anything smarter must beat it.
class PixelDescriptor : public DescriptorExtractor {
 public:
  static constexpr int kWidth = 32;
  static constexpr int kHeight = 24;

  std::string name() const override { return "pixels"; }
  int globalDimension() const override { return kWidth * kHeight; }
  ImageDescriptor describe(const cv::Mat& image) const override;
};

/// Baseline: one HOG window over the whole 160x120 grey image with OpenCV's default block
/// (16x16), block stride (8x8), cell (8x8) and 9 bins: 9576 values, L2-normalised.
class WholeImageHogDescriptor : public DescriptorExtractor {
 public:
  static constexpr int kDimension = 9576;

  WholeImageHogDescriptor();
  std::string name() const override { return "hog_whole"; }
  int globalDimension() const override { return kDimension; }
  ImageDescriptor describe(const cv::Mat& image) const override;

 private:
  cv::HOGDescriptor hog_;
};

}  // namespace landmark_loop_closure
