#include "landmark_loop_closure/common/image_helpers.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {

cv::Mat toWorkingImage(const cv::Mat& image, int width, int height) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = image;
  }
  if (grey.depth() != CV_8U) {
    cv::Mat scaled;
    grey.convertTo(scaled, CV_8U, grey.depth() == CV_16U ? 1.0 / 256.0 : 1.0);
    grey = scaled;
  }
  if (grey.cols == width && grey.rows == height) return grey;
  cv::Mat resized;
  cv::resize(grey, resized, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  return resized;
}

void centreAndNormalise(std::vector<float>* values) {
  if (values->empty()) return;
  double mean = 0.0;
  for (const float v : *values) mean += v;
  mean /= static_cast<double>(values->size());
  for (float& v : *values) v -= static_cast<float>(mean);
  normaliseL2(values);
}

void normaliseL2(float* begin, float* end) {
  double sum = 0.0;
  for (const float* v = begin; v != end; ++v) sum += static_cast<double>(*v) * *v;
  if (!(sum > 0.0) || !std::isfinite(sum)) return;
  const float scale = static_cast<float>(1.0 / std::sqrt(sum));
  for (float* v = begin; v != end; ++v) *v *= scale;
}

void normaliseL2(std::vector<float>* values) {
  normaliseL2(values->data(), values->data() + values->size());
}

}  // namespace landmark_loop_closure
