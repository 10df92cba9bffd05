#include "landmark_loop_closure/core/match_image.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {

namespace {

constexpr int kBandHeight = 64;
const cv::Scalar kInlierColour(60, 220, 60);

cv::Mat toColourAtHeight(const cv::Mat& image, int height) {
  if (image.empty()) return cv::Mat(height, height * 4 / 3, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat colour;
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

cv::Scalar verdictColour(MatchView::Verdict verdict) {
  switch (verdict) {
    case MatchView::Verdict::kAccepted:
      return {40, 150, 40};
    case MatchView::Verdict::kCandidate:
      return {0, 120, 230};
    case MatchView::Verdict::kRejected:
      break;
  }
  return {110, 110, 110};
}

// Hues spread around the colour wheel so that neighbouring pairs differ.
cv::Scalar pairColour(size_t index) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<double>((index * 47) % 180), 255, 255));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

}  // namespace

cv::Mat renderMatchImage(const MatchView& view, int height) {
  const cv::Mat left = toColourAtHeight(view.query, height);
  const cv::Mat right = toColourAtHeight(view.match, height);
  const int width = left.cols + right.cols;
  cv::Mat canvas(kBandHeight + height, width, CV_8UC3, cv::Scalar(0, 0, 0));
  canvas(cv::Rect(0, 0, width, kBandHeight)).setTo(verdictColour(view.verdict));
  const cv::Scalar white(255, 255, 255);
  cv::putText(canvas, view.headline, cv::Point(10, 28), cv::FONT_HERSHEY_SIMPLEX, 0.8, white, 2,
              cv::LINE_AA);
  cv::putText(canvas, view.details, cv::Point(10, 54), cv::FONT_HERSHEY_SIMPLEX, 0.55, white, 1,
              cv::LINE_AA);
  left.copyTo(canvas(cv::Rect(0, kBandHeight, left.cols, left.rows)));
  right.copyTo(canvas(cv::Rect(left.cols, kBandHeight, right.cols, right.rows)));
  cv::line(canvas, cv::Point(left.cols, kBandHeight), cv::Point(left.cols, kBandHeight + height),
           white);

  const double query_scale =
      view.query.empty() ? 1.0 : static_cast<double>(height) / view.query.rows;
  const double match_scale =
      view.match.empty() ? 1.0 : static_cast<double>(height) / view.match.rows;
  const auto box = [&](const cv::Rect2f& r, double scale, int x_offset) {
    return cv::Rect(x_offset + cvRound(r.x * scale), kBandHeight + cvRound(r.y * scale),
                    cvRound(r.width * scale), cvRound(r.height * scale));
  };
  const auto point = [&](const cv::Point2f& p, double scale, int x_offset) {
    return cv::Point(x_offset + cvRound(p.x * scale), kBandHeight + cvRound(p.y * scale));
  };
  const size_t pairs = std::min(view.landmark_pairs.size(), MatchView::kMaxLandmarkPairs);
  for (size_t i = 0; i < pairs; ++i) {
    const cv::Scalar colour = pairColour(i);
    cv::rectangle(canvas, box(view.landmark_pairs[i].first, query_scale, 0), colour, 2);
    cv::rectangle(canvas, box(view.landmark_pairs[i].second, match_scale, left.cols), colour, 2);
  }
  for (const auto& [query_point, match_point] : view.inliers) {
    const cv::Point a = point(query_point, query_scale, 0);
    const cv::Point b = point(match_point, match_scale, left.cols);
    cv::line(canvas, a, b, kInlierColour, 1, cv::LINE_AA);
    cv::circle(canvas, a, 3, kInlierColour, cv::FILLED);
    cv::circle(canvas, b, 3, kInlierColour, cv::FILLED);
  }
  return canvas;
}

}  // namespace landmark_loop_closure
