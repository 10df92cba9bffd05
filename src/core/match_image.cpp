#include "landmark_loop_closure/core/match_image.h"

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
                         bool accepted, int height,
                         const std::vector<std::pair<cv::Rect2f, cv::Rect2f>>& matched_boxes,
                         const std::vector<std::pair<cv::Point2f, cv::Point2f>>& matched_points) {
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
  const double query_scale = query.empty() ? 1.0 : static_cast<double>(height) / query.rows;
  const double match_scale = match.empty() ? 1.0 : static_cast<double>(height) / match.rows;
  const auto scaled = [](const cv::Rect2f& box, double scale, int x_offset) {
    return cv::Rect(x_offset + cvRound(box.x * scale), cvRound(box.y * scale),
                    cvRound(box.width * scale), cvRound(box.height * scale));
  };
  for (size_t i = 0; i < matched_boxes.size(); ++i) {
    // Hues spread around the colour wheel so that neighbouring pairs differ.
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<double>((i * 47) % 180), 255, 255));
    cv::Mat bgr;
    cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
    const cv::Scalar pair_colour(c[0], c[1], c[2]);
    cv::rectangle(canvas, scaled(matched_boxes[i].first, query_scale, 0), pair_colour, 1);
    cv::rectangle(canvas, scaled(matched_boxes[i].second, match_scale, left.cols), pair_colour, 1);
  }
  const cv::Scalar inlier_colour(60, 220, 60);
  for (const auto& [query_point, match_point] : matched_points) {
    const cv::Point a(cvRound(query_point.x * query_scale), cvRound(query_point.y * query_scale));
    const cv::Point b(left.cols + cvRound(match_point.x * match_scale),
                      cvRound(match_point.y * match_scale));
    cv::line(canvas, a, b, inlier_colour, 1, cv::LINE_AA);
    cv::circle(canvas, a, 2, inlier_colour, cv::FILLED);
    cv::circle(canvas, b, 2, inlier_colour, cv::FILLED);
  }
  return canvas;
}

}  // namespace landmark_loop_closure
