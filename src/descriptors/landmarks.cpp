#include "landmark_loop_closure/descriptors/landmarks.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include <opencv2/objdetect.hpp>
#include "landmark_loop_closure/common/image_helpers.h"

namespace landmark_loop_closure {

FeatureMaps featureMapsFromBlob(const cv::Mat& blob) {
  if (blob.dims != 4 || blob.size[0] != 1 || blob.type() != CV_32F) {
    throw std::runtime_error("expected a 1xCxHxW float output from the network");
  }
  FeatureMaps maps;
  maps.channels = blob.size[1];
  maps.height = blob.size[2];
  maps.width = blob.size[3];
  const float* data = blob.ptr<float>();
  maps.values.assign(data, data + static_cast<size_t>(maps.channels) * maps.height * maps.width);
  return maps;
}

namespace {

double intersectionOverUnion(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float intersection = (a & b).area();
  const float united = a.area() + b.area() - intersection;
  return united > 0.0f ? intersection / united : 0.0;
}

// Bilinear sample of one channel at continuous cell coordinates (cell centres at integers).
float sample(const FeatureMaps& maps, int c, float y, float x) {
  x = std::clamp(x, 0.0f, static_cast<float>(maps.width - 1));
  y = std::clamp(y, 0.0f, static_cast<float>(maps.height - 1));
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  const int x1 = std::min(x0 + 1, maps.width - 1);
  const int y1 = std::min(y0 + 1, maps.height - 1);
  const float fx = x - x0;
  const float fy = y - y0;
  const float top = maps.at(c, y0, x0) * (1 - fx) + maps.at(c, y0, x1) * fx;
  const float bottom = maps.at(c, y1, x0) * (1 - fx) + maps.at(c, y1, x1) * fx;
  return top * (1 - fy) + bottom * fy;
}

}  // namespace

std::vector<LandmarkProposal> proposeLandmarks(const FeatureMaps& maps, cv::Size image_size,
                                               const LandmarkProposalOptions& options) {
  std::vector<LandmarkProposal> candidates;
  if (maps.empty() || image_size.area() == 0) return candidates;
  const float scale_x = static_cast<float>(image_size.width) / maps.width;
  const float scale_y = static_cast<float>(image_size.height) / maps.height;
  const double max_cells = options.max_area_fraction * maps.width * maps.height;
  cv::Mat mask(maps.height, maps.width, CV_8UC1);
  cv::Mat labels;
  cv::Mat stats;
  cv::Mat centroids;
  std::vector<double> sums;
  for (int c = 0; c < maps.channels; ++c) {
    const cv::Mat activation(maps.height, maps.width, CV_32F, const_cast<float*>(maps.channel(c)));
    mask = activation > 0.0f;
    const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
    sums.assign(static_cast<size_t>(count), 0.0);
    for (int y = 0; y < maps.height; ++y) {
      const int* label = labels.ptr<int>(y);
      const float* value = activation.ptr<float>(y);
      for (int x = 0; x < maps.width; ++x) sums[label[x]] += label[x] ? value[x] : 0.0;
    }
    for (int label = 1; label < count; ++label) {  // Label 0 is the background.
      const int width = stats.at<int>(label, cv::CC_STAT_WIDTH);
      const int height = stats.at<int>(label, cv::CC_STAT_HEIGHT);
      if (width < options.min_side_cells || height < options.min_side_cells) continue;
      if (static_cast<double>(width) * height > max_cells) continue;
      LandmarkProposal proposal;
      proposal.cells = cv::Rect(stats.at<int>(label, cv::CC_STAT_LEFT),
                                stats.at<int>(label, cv::CC_STAT_TOP), width, height);
      proposal.box = cv::Rect2f(proposal.cells.x * scale_x, proposal.cells.y * scale_y,
                                width * scale_x, height * scale_y);
      proposal.energy = sums[label] / stats.at<int>(label, cv::CC_STAT_AREA);
      proposal.channel = c;
      candidates.push_back(proposal);
    }
  }
  std::stable_sort(
      candidates.begin(), candidates.end(),
      [](const LandmarkProposal& a, const LandmarkProposal& b) { return a.energy > b.energy; });
  std::vector<LandmarkProposal> kept;
  for (const LandmarkProposal& candidate : candidates) {
    if (static_cast<int>(kept.size()) >= options.max_landmarks) break;
    const bool duplicate = std::any_of(kept.begin(), kept.end(), [&](const LandmarkProposal& k) {
      return intersectionOverUnion(k.box, candidate.box) > options.max_overlap;
    });
    if (!duplicate) kept.push_back(candidate);
  }
  return kept;
}

cv::Mat describeLandmarks(const FeatureMaps& maps, cv::Size image_size,
                          const std::vector<cv::Rect2f>& boxes, int grid) {
  cv::Mat features(static_cast<int>(boxes.size()), maps.channels * grid * grid, CV_32F,
                   cv::Scalar(0));
  if (maps.empty() || image_size.area() == 0) return features;
  const float cells_per_pixel_x = static_cast<float>(maps.width) / image_size.width;
  const float cells_per_pixel_y = static_cast<float>(maps.height) / image_size.height;
  for (size_t i = 0; i < boxes.size(); ++i) {
    const cv::Rect2f& box = boxes[i];
    float* row = features.ptr<float>(static_cast<int>(i));
    for (int c = 0; c < maps.channels; ++c) {
      for (int gy = 0; gy < grid; ++gy) {
        // Sample at the centre of each grid cell; -0.5 turns pixel edges into cell centres.
        const float y = (box.y + (gy + 0.5f) * box.height / grid) * cells_per_pixel_y - 0.5f;
        for (int gx = 0; gx < grid; ++gx) {
          const float x = (box.x + (gx + 0.5f) * box.width / grid) * cells_per_pixel_x - 0.5f;
          *row++ = sample(maps, c, y, x);
        }
      }
    }
    cv::Mat r = features.row(static_cast<int>(i));
    const double norm = cv::norm(r);
    if (norm > 0.0) r /= norm;
  }
  return features;
}

cv::Mat describeLandmarksByHog(const cv::Mat& image, cv::Size box_frame,
                               const std::vector<cv::Rect2f>& boxes, int patch_side) {
  const int dimension = kLandmarkHogDimension;
  cv::Mat features(static_cast<int>(boxes.size()), dimension, CV_32F, cv::Scalar(0));
  if (image.empty() || box_frame.area() == 0) return features;
  const int cell = patch_side / 4;
  const cv::HOGDescriptor hog(cv::Size(patch_side, patch_side), cv::Size(2 * cell, 2 * cell),
                              cv::Size(cell, cell), cv::Size(cell, cell), 9);
  const float scale_x = static_cast<float>(image.cols) / box_frame.width;
  const float scale_y = static_cast<float>(image.rows) / box_frame.height;
  const cv::Rect bounds(0, 0, image.cols, image.rows);
  cv::Mat patch;
  std::vector<float> values;
  for (size_t i = 0; i < boxes.size(); ++i) {
    const cv::Rect2f& box = boxes[i];
    const cv::Rect crop = cv::Rect(cv::Rect2f(box.x * scale_x, box.y * scale_y, box.width * scale_x,
                                              box.height * scale_y)) &
                          bounds;
    if (crop.area() == 0) continue;
    cv::resize(image(crop), patch, cv::Size(patch_side, patch_side), 0, 0, cv::INTER_AREA);
    hog.compute(patch, values);
    if (static_cast<int>(values.size()) != dimension) continue;
    centreAndNormalise(&values);
    std::copy(values.begin(), values.end(), features.ptr<float>(static_cast<int>(i)));
  }
  return features;
}

std::vector<LandmarkMatch> matchLandmarks(const cv::Mat& stored_a, const cv::Mat& stored_b) {
  std::vector<LandmarkMatch> matches;
  if (stored_a.empty() || stored_b.empty() || stored_a.cols != stored_b.cols) {
    return matches;
  }
  cv::Mat features_a = stored_a;
  cv::Mat features_b = stored_b;
  if (features_a.depth() != CV_32F) stored_a.convertTo(features_a, CV_32F);
  if (features_b.depth() != CV_32F) stored_b.convertTo(features_b, CV_32F);
  const cv::Mat cosine = features_a * features_b.t();
  std::vector<int> best_for_b(static_cast<size_t>(cosine.cols));
  for (int v = 0; v < cosine.cols; ++v) {
    cv::Point best;
    cv::minMaxLoc(cosine.col(v), nullptr, nullptr, nullptr, &best);
    best_for_b[v] = best.y;
  }
  for (int u = 0; u < cosine.rows; ++u) {
    cv::Point best;
    cv::minMaxLoc(cosine.row(u), nullptr, nullptr, nullptr, &best);
    if (best_for_b[best.x] == u) matches.push_back({u, best.x, cosine.at<float>(u, best.x)});
  }
  return matches;
}

double landmarkSimilarity(const std::vector<cv::Rect2f>& boxes_a, const cv::Mat& features_a,
                          const std::vector<cv::Rect2f>& boxes_b, const cv::Mat& features_b,
                          ShapeWeighting weighting) {
  if (boxes_a.empty() || boxes_b.empty() || features_a.rows != static_cast<int>(boxes_a.size()) ||
      features_b.rows != static_cast<int>(boxes_b.size())) {
    return 0.0;
  }
  double sum = 0.0;
  for (const LandmarkMatch& match : matchLandmarks(features_a, features_b)) {
    const cv::Rect2f& a = boxes_a[match.a];
    const cv::Rect2f& b = boxes_b[match.b];
    const double shape = std::exp(std::abs(a.height - b.height) / std::max(a.height, b.height) +
                                  std::abs(a.width - b.width) / std::max(a.width, b.width));
    sum += weighting == ShapeWeighting::kPenalise ? 1.0 - shape * (1.0 - match.cosine)
                                                  : shape * match.cosine;
  }
  return sum / std::sqrt(static_cast<double>(boxes_a.size()) * boxes_b.size());
}

}  // namespace landmark_loop_closure
