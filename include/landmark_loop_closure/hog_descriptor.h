#pragma once

#include <opencv2/objdetect.hpp>

#include "landmark_loop_closure/descriptor.h"

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

/// Resizes (bicubic) to width x height; converts to grey first if needed.
cv::Mat toWorkingImage(const cv::Mat& image, int width, int height);

/// Scales a vector to unit L2 norm; leaves an all-zero vector as it is.
void normaliseL2(std::vector<float>* values);

/// Subtracts the vector's own mean, then normalises to unit L2 norm, so that the cosine of two
/// such vectors is their correlation. HOG values are all positive: without centring, every pair
/// of images scores a cosine near 1 and the threshold has no room.
void centreAndNormalise(std::vector<float>* values);

}  // namespace landmark_loop_closure
