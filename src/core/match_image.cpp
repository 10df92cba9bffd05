#include "landmark_loop_closure/match_image.h"

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {

namespace {

cv::Mat toColourAtHeight(const cv::Mat& image, int height) {
  cv::Mat colour;
  if (image.empty()) {
    colour = cv::Mat(height, height * 4 / 3, CV_8UC3, cv::Scalar(40, 40, 40));
    return colour;
  }
  if (image.channels() == 1) {
    cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  } else {
    colour = image;
  }
  const int width = std::max(1, image.cols * height / std::max(1, image.rows));
  cv::Mat resized;
  cv::resize(colour, resized, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
  return resized;
}

}  // namespace

cv::Mat renderMatchImage(const cv::Mat& query, const cv::Mat& match, const std::string& caption,
                         bool accepted, int height) {
  constexpr int kCaptionHeight = 28;
  const cv::Mat left = toColourAtHeight(query, height);
  const cv::Mat right = toColourAtHeight(match, height);
  cv::Mat canvas(height + kCaptionHeight, left.cols + right.cols, CV_8UC3, cv::Scalar(0, 0, 0));
  left.copyTo(canvas(cv::Rect(0, 0, left.cols, left.rows)));
  right.copyTo(canvas(cv::Rect(left.cols, 0, right.cols, right.rows)));
  const cv::Scalar colour = accepted ? cv::Scalar(80, 220, 80) : cv::Scalar(60, 60, 230);
  cv::putText(canvas, caption, cv::Point(6, height + 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, colour, 1,
              cv::LINE_AA);
  cv::line(canvas, cv::Point(left.cols, 0), cv::Point(left.cols, height),
           cv::Scalar(255, 255, 255));
  return canvas;
}

}  // namespace landmark_loop_closure
