// Image and vector helpers the descriptors and the geometric check share.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Resizes (bicubic) to width x height; converts to grey first if needed.
cv::Mat toWorkingImage(const cv::Mat& image, int width, int height);

/// Scales a vector to unit L2 norm; leaves an all-zero (or non-finite) vector as it is.
void normaliseL2(std::vector<float>* values);
/// The same for the values [begin, end), e.g. one cell of a longer vector.
void normaliseL2(float* begin, float* end);

/// Subtracts the vector's own mean, then normalises to unit L2 norm, so that the cosine of two
/// such vectors is their correlation. HOG values are all positive: without centring, every pair
/// of images scores a cosine near 1 and the threshold has no room.
void centreAndNormalise(std::vector<float>* values);

}  // namespace landmark_loop_closure
