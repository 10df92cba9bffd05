#pragma once

#include <opencv2/objdetect.hpp>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// Whole-image HOG with the settings CALC reconstructs: 160x120 grey image, window 16x32,
/// block 16x16, block stride 16x16, cell 8x8, 2 bins, window stride 8 -> 3648 values,
/// centred and L2-normalised (see centreAndNormalise).
class HogDescriptor : public DescriptorExtractor {
 public:
  static constexpr int kWidth = 160;
  static constexpr int kHeight = 120;
  static constexpr int kDimension = 3648;

  HogDescriptor();

  std::string name() const override { return "hog"; }
  int globalDimension() const override { return kDimension; }
  ImageDescriptor describe(const cv::Mat& image) const override;

 private:
  cv::HOGDescriptor hog_;
};

}  // namespace landmark_loop_closure
