#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Query (left) and match (right) side by side, both scaled to `height`, with a caption line
/// under them (ids and score). Grey inputs are shown in colour so the caption can be coloured.
/// `matched_boxes`: pairs of landmark boxes (query box, match box), each in its own image's
/// pixels; every pair is drawn in a colour of its own, as in the landmark paper's figure.
/// `matched_points`: geometric inliers (query point, match point), each in its own image's
/// pixels, drawn as green dots joined by a line.
cv::Mat renderMatchImage(
    const cv::Mat& query, const cv::Mat& match, const std::string& caption, bool accepted,
    int height = 240, const std::vector<std::pair<cv::Rect2f, cv::Rect2f>>& matched_boxes = {},
    const std::vector<std::pair<cv::Point2f, cv::Point2f>>& matched_points = {});

}  // namespace landmark_loop_closure
