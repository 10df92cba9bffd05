#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace landmark_loop_closure {

/// A stack of feature maps from one CNN layer: channels x height x width, channel-major.
struct FeatureMaps {
  int channels = 0;
  int height = 0;
  int width = 0;
  std::vector<float> values;

  const float* channel(int c) const {
    return values.data() + static_cast<size_t>(c) * height * width;
  }
  float at(int c, int y, int x) const { return channel(c)[y * width + x]; }
  bool empty() const { return values.empty(); }
};

/// A network's 1xCxHxW float output as feature maps; throws std::runtime_error for another shape.
FeatureMaps featureMapsFromBlob(const cv::Mat& blob);

struct LandmarkProposalOptions {
  int max_landmarks = 50;    ///< M: the landmarks kept per image, highest energy first.
  int min_side_cells = 2;    ///< A component narrower or shorter than this (map cells) is noise.
  double max_overlap = 0.5;  ///< Non-maximum suppression: IoU above which the weaker box goes.
  double max_area_fraction = 0.5;  ///< A box covering more of the image than this is no landmark.
};

struct LandmarkProposal {
  cv::Rect2f box;       ///< In image pixels.
  cv::Rect cells;       ///< In feature-map cells.
  double energy = 0.0;  ///< Mean activation over the component.
  int channel = 0;
};

/// Landmarks straight from a conv layer: in every channel, 8-connected components of positive
/// activations, each scored by its mean activation; boxes mapped to an image of `image_size`;
/// small ones dropped, near-duplicates suppressed, the `max_landmarks` strongest kept, strongest
/// first.
std::vector<LandmarkProposal> proposeLandmarks(const FeatureMaps& maps, cv::Size image_size,
                                               const LandmarkProposalOptions& options);

/// One descriptor per box, cut from a feature map of the whole image (one network pass for all
/// landmarks): the maps inside the box resampled bilinearly to grid x grid cells per channel,
/// L2-normalised. Returns boxes.size() rows of channels * grid * grid CV_32F values.
cv::Mat describeLandmarks(const FeatureMaps& maps, cv::Size image_size,
                          const std::vector<cv::Rect2f>& boxes, int grid);

/// One descriptor per box from the image itself: the box (in the coordinates of an image of
/// `box_frame` size, scaled to `image`) resampled to patch_side x patch_side pixels and described
/// by HOG (cell patch_side/4, blocks of 2x2 cells, stride one cell, 9 bins), centred and
/// L2-normalised. Returns boxes.size() rows of CV_32F; `image` is 8-bit grey.
cv::Mat describeLandmarksByHog(const cv::Mat& image, cv::Size box_frame,
                               const std::vector<cv::Rect2f>& boxes, int patch_side);

/// Length of a describeLandmarksByHog row: 3x3 blocks x 4 cells x 9 bins.
constexpr int kLandmarkHogDimension = 324;

/// How box shapes weight a landmark match (see methods.md, section 1, the open question).
enum class ShapeWeighting {
  kPenalise,  ///< Sünderhauf et al.: sum [1 - s (1 - cos)]: shape disagreement lowers the score.
  kPaper,     ///< As printed: sum s * cos, which rewards shape disagreement.
};

/// A mutual-nearest-neighbour pair: landmark `a` of the first image, `b` of the second.
struct LandmarkMatch {
  int a = 0;
  int b = 0;
  double cosine = 0.0;
};

/// Mutual nearest neighbours by cosine of two landmark sets, stored as CV_32F or CV_16F (empty
/// when either is empty or the feature lengths differ).
std::vector<LandmarkMatch> matchLandmarks(const cv::Mat& features_a, const cv::Mat& features_b);

/// Similarity of two images from their landmarks: mutual nearest neighbours by cosine, each
/// pair weighted by s = exp(|h_a - h_b| / max(h) + |w_a - w_b| / max(w)), the sum normalised by
/// sqrt(n_a * n_b). Symmetric in its two arguments; 0 when either side has no landmark.
double landmarkSimilarity(const std::vector<cv::Rect2f>& boxes_a, const cv::Mat& features_a,
                          const std::vector<cv::Rect2f>& boxes_b, const cv::Mat& features_b,
                          ShapeWeighting weighting);

}  // namespace landmark_loop_closure
