#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/ground_truth.h"
#include "landmark_loop_closure/eval/metrics.h"

namespace landmark_loop_closure {
namespace eval {

/// Image files of a folder (png, jpg, jpeg, bmp, pgm, ppm, tif, tiff), sorted by name with
/// digit runs compared as numbers (naturalLess). Throws GroundTruthError when the folder is
/// missing or holds no image.
std::vector<std::string> listImages(const std::string& folder);

/// Name order with digit runs compared as numbers: "2.jpg" < "10.jpg", "img9" < "img010".
bool naturalLess(const std::string& a, const std::string& b);
/// True when sorting `paths` as plain text would give another order (worth a warning: a tool
/// that sorts as text would pair other images with the ground truth).
bool textOrderDiffers(const std::vector<std::string>& paths);

/// Called now and then with (done, total) during long runs.
using Progress = std::function<void(size_t done, size_t total)>;

/// Descriptors of a list of images, in order. An image that does not decode keeps its slot
/// (so ground-truth indices stay aligned), is marked invalid and is never matched.
struct DescribedImages {
  std::vector<ImageDescriptor> descriptors;
  std::vector<bool> valid;
  std::vector<double> describe_ms;
  std::vector<std::string> undecodable;

  size_t size() const { return descriptors.size(); }
};

/// `load(i)` returns image i (empty when it cannot be read).
DescribedImages describeImages(size_t count, const std::function<cv::Mat(size_t)>& load,
                               const DescriptorExtractor& extractor, const Progress& progress = {});
/// With `width` > 0 every image is first scaled to that many pixels wide (readImage).
DescribedImages describeImageFiles(const std::vector<std::string>& paths,
                                   const DescriptorExtractor& extractor,
                                   const Progress& progress = {}, int width = 0);

/// How a traversal's first images are standardised, as the detector treats a run's first
/// keyframes while its window fills.
enum class ConditionStart {
  kSearched,  ///< Against the images so far (a query is searched so; the first is zeros).
  kStored,    ///< The first `window - 1` against the first full window (a mapping run stores
              ///< them so, once the window is full); a shorter traversal as searched.
};

/// Each valid image's global vector standardised as the detector standardises a camera's
/// keyframes (ConditionStandardiser, `window` images, in list order): one traversal, one
/// condition. 0 leaves them as described.
void standardiseConditions(DescribedImages* images, int window,
                           ConditionStart start = ConditionStart::kSearched);

/// Reads an image file, in colour or grey; with `width` > 0 scaled to that many pixels wide,
/// aspect kept, by area averaging (what a smaller camera would see). Empty when it does not
/// decode.
cv::Mat readImage(const std::string& path, bool colour, int width = 0);

struct MatchingOptions {
  /// Sequence mode (queries == database): image i is only matched against images j with
  /// j < i - exclude_recent, as an online detector would.
  int exclude_recent = 0;
  /// When the extractor re-ranks: how many global-descriptor candidates it re-scores.
  int shortlist = 10;
  /// Largest side of the similarity-matrix picture (max-pooled down to it).
  int matrix_size = 1000;
};

struct Evaluation {
  std::string name;
  /// What a learned descriptor was trained on ("" when it learns nothing from images).
  std::string training_source;
  Metrics metrics;
  std::vector<QueryOutcome> outcomes;
  Percentiles describe_ms;
  Percentiles query_ms;
  double bytes_per_image = 0.0;
  size_t undecodable = 0;
  cv::Mat similarity;  ///< CV_32F, queries x database, max-pooled to at most matrix_size.
  /// What the node's checks did to the best matches ("" when they did not run).
  std::string match_checks;
};

/// Traversal matching: every query against every database image. `truth` is queries x database.
Evaluation evaluateTraversals(const DescribedImages& database, const DescribedImages& queries,
                              const GroundTruth& truth, const DescriptorExtractor& extractor,
                              const MatchingOptions& options, const Progress& progress = {});

/// Sequence matching: each image against the earlier ones outside the exclusion window.
/// `truth` is square over the sequence (use GroundTruth::undirected() for one-sided files).
Evaluation evaluateSequence(const DescribedImages& images, const GroundTruth& truth,
                            const DescriptorExtractor& extractor, const MatchingOptions& options,
                            const Progress& progress = {});

/// The ground truth drawn on the same grid as Evaluation::similarity (white = same place).
cv::Mat groundTruthPicture(const GroundTruth& truth, int matrix_size);

}  // namespace eval
}  // namespace landmark_loop_closure
