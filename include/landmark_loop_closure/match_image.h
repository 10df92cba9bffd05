#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// Query (left) and match (right) side by side, both scaled to `height`, with a caption line
/// under them (ids and score). Grey inputs are shown in colour so the caption can be coloured.
cv::Mat renderMatchImage(const cv::Mat& query, const cv::Mat& match, const std::string& caption,
                         bool accepted, int height = 240);

}  // namespace landmark_loop_closure
