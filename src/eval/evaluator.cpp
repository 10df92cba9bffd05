#include "landmark_loop_closure/eval/evaluator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

namespace fs = std::filesystem;

bool isImageFile(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  static const char* kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp",
                                      ".pgm", ".ppm", ".tif",  ".tiff"};
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&extension](const char* e) { return extension == e; });
}

// Max-pools scores into a picture grid of at most `size` per side.
class SimilarityGrid {
 public:
  SimilarityGrid(size_t rows, size_t cols, int size)
      : rows_(rows),
        cols_(cols),
        grid_(static_cast<int>(std::min<size_t>(rows, size)),
              static_cast<int>(std::min<size_t>(cols, size)), CV_32F, cv::Scalar(-1.0f)) {}

  void add(size_t row, size_t col, double score) {
    const int r = static_cast<int>(row * grid_.rows / std::max<size_t>(1, rows_));
    const int c = static_cast<int>(col * grid_.cols / std::max<size_t>(1, cols_));
    float& cell = grid_.at<float>(r, c);
    cell = std::max(cell, static_cast<float>(score));
  }
  cv::Mat take() { return grid_; }

 private:
  size_t rows_;
  size_t cols_;
  cv::Mat grid_;
};

// The database images searched as the node searches its keyframes: a KeyframeDatabase (exact
// search, no exclusion windows) filled with valid images in order, image j as keyframe id j + 1,
// each as a map file keeps it.
class DatabaseSearch {
 public:
  DatabaseSearch(const DescribedImages& images, const DescriptorExtractor& extractor,
                 const MatchingOptions& options)
      : images_(images),
        database_(extractor.globalDimension()),
        stored_(images.descriptors.size()) {
    search_.exclude_recent_keyframes = 0;
    search_.exclude_recent_seconds = 0.0;
    search_.min_size = 1;
    search_.top_k = extractor.reranks() ? std::max(1, options.shortlist) : 1;
    search_.index.type = "exact";
  }

  /// Makes images [0, end) searchable (only ever grows).
  void growTo(size_t end) {
    for (; added_ < end; ++added_) {
      if (!images_.valid[added_]) continue;
      KeyframeRecord record;
      record.id = added_ + 1;
      record.stamp = static_cast<double>(added_);
      record.descriptor = images_.descriptors[added_];
      record = KeyframeStore::asStored(record);
      stored_[added_] = record.descriptor;
      database_.add(std::move(record));
    }
  }

  /// Database image `index` as a map file gives it back for re-ranking (8-bit landmark features).
  const ImageDescriptor& stored(size_t index) const { return stored_.at(index); }

  /// The shortlist of `query`, best global score first, as database image indices and scores.
  std::vector<Candidate> shortlist(const ImageDescriptor& query) const {
    const QueryResult found = database_.query(query.global, 0.0, search_);
    std::vector<Candidate> candidates = found.candidates;
    for (Candidate& candidate : candidates) candidate.index = candidate.id - 1;
    return candidates;
  }

 private:
  const DescribedImages& images_;
  KeyframeDatabase database_;
  std::vector<ImageDescriptor> stored_;
  DatabaseOptions search_;
  size_t added_ = 0;
};

// Every pair's global score of one query, for the similarity picture (not timed: the search
// scores them again, as the node would).
void drawQuery(size_t query_index, const ImageDescriptor& query, const DescribedImages& database,
               size_t end, const DescriptorExtractor& extractor, SimilarityGrid* grid) {
  for (size_t j = 0; j < end; ++j) {
    if (!database.valid[j]) continue;
    grid->add(
        query_index, j,
        extractor.globalScore(cosineSimilarity(query.global, database.descriptors[j].global)));
  }
}

// Best database match of one query among the searchable images (skipping invalid ones).
QueryOutcome matchQuery(size_t query_index, const ImageDescriptor& query,
                        const DescribedImages& database, size_t end, const DatabaseSearch& search,
                        const GroundTruth& truth, const DescriptorExtractor& extractor) {
  QueryOutcome outcome;
  outcome.query = query_index;
  outcome.has_truth = false;
  for (const uint32_t place : truth.positives(query_index)) {
    if (place < end && database.valid[place]) {
      outcome.has_truth = true;
      break;
    }
  }
  // A vector of zeros (a traversal's first image after the condition standardisation) ties
  // every image at 0 and the node matches nothing with it: a miss, not a lucky tie.
  const bool carries_nothing =
      std::all_of(query.global.begin(), query.global.end(), [](float v) { return v == 0.0f; });
  if (carries_nothing) return outcome;
  const std::vector<Candidate> candidates = search.shortlist(query);
  if (candidates.empty()) return outcome;
  // Re-ranked as the detector re-ranks: the extractor's similarity, or the global score.
  size_t best = candidates[0].index;
  double best_score = -std::numeric_limits<double>::infinity();
  for (const Candidate& candidate : candidates) {
    const double score = extractor.reranks()
                             ? extractor.similarity(query, search.stored(candidate.index))
                             : extractor.globalScore(candidate.global_score);
    if (score > best_score) {
      best_score = score;
      best = candidate.index;
    }
  }
  outcome.match = static_cast<long>(best);
  outcome.score = best_score;
  outcome.correct = truth.contains(query_index, best);
  return outcome;
}

Evaluation summarise(const std::string& name, std::vector<QueryOutcome> outcomes,
                     std::vector<double> query_ms, const DescribedImages& database,
                     const DescribedImages* queries, SimilarityGrid* grid) {
  Evaluation evaluation;
  evaluation.name = name;
  evaluation.metrics = computeMetrics(outcomes);
  evaluation.outcomes = std::move(outcomes);
  std::vector<double> describe = database.describe_ms;
  size_t bytes = 0;
  size_t described = 0;
  for (size_t i = 0; i < database.size(); ++i) {
    if (!database.valid[i]) continue;
    bytes += database.descriptors[i].bytes();
    ++described;
  }
  evaluation.undecodable = database.undecodable.size();
  if (queries) {
    describe.insert(describe.end(), queries->describe_ms.begin(), queries->describe_ms.end());
    evaluation.undecodable += queries->undecodable.size();
  }
  evaluation.describe_ms = percentiles(describe);
  evaluation.query_ms = percentiles(std::move(query_ms));
  evaluation.bytes_per_image = described ? static_cast<double>(bytes) / described : 0.0;
  evaluation.similarity = grid->take();
  return evaluation;
}

}  // namespace

std::vector<std::string> listImages(const std::string& folder) {
  if (!fs::is_directory(folder))
    throw GroundTruthError("image folder " + folder + " does not exist");
  std::vector<std::string> paths;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && isImageFile(entry.path()))
      paths.push_back(entry.path().string());
  }
  if (paths.empty()) throw GroundTruthError("image folder " + folder + " holds no image");
  std::sort(paths.begin(), paths.end(), naturalLess);
  return paths;
}

bool naturalLess(const std::string& a, const std::string& b) {
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  size_t i = 0;
  size_t j = 0;
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      size_t end_a = i;
      size_t end_b = j;
      while (end_a < a.size() && digit(a[end_a])) ++end_a;
      while (end_b < b.size() && digit(b[end_b])) ++end_b;
      // Compare the numbers without their leading zeros: longer is larger, else digit by digit.
      size_t start_a = i;
      size_t start_b = j;
      while (start_a + 1 < end_a && a[start_a] == '0') ++start_a;
      while (start_b + 1 < end_b && b[start_b] == '0') ++start_b;
      const size_t length_a = end_a - start_a;
      const size_t length_b = end_b - start_b;
      if (length_a != length_b) return length_a < length_b;
      const int order = a.compare(start_a, length_a, b, start_b, length_b);
      if (order != 0) return order < 0;
      // Same number: fewer leading zeros first, so the order stays total.
      if (end_a - i != end_b - j) return end_a - i < end_b - j;
      i = end_a;
      j = end_b;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool textOrderDiffers(const std::vector<std::string>& paths) {
  std::vector<std::string> text = paths;
  std::sort(text.begin(), text.end());
  std::vector<std::string> natural = paths;
  std::sort(natural.begin(), natural.end(), naturalLess);
  return text != natural;
}

DescribedImages describeImages(size_t count, const std::function<cv::Mat(size_t)>& load,
                               const DescriptorExtractor& extractor, const Progress& progress) {
  DescribedImages result;
  result.descriptors.resize(count);
  result.valid.assign(count, false);
  for (size_t i = 0; i < count; ++i) {
    const cv::Mat image = load(i);
    if (image.empty()) {
      result.undecodable.push_back(std::to_string(i));
    } else {
      const auto start = Clock::now();
      result.descriptors[i] = extractor.describe(image);
      result.describe_ms.push_back(millisecondsSince(start));
      result.valid[i] = true;
    }
    if (progress) progress(i + 1, count);
  }
  return result;
}

void standardiseConditions(DescribedImages* images, int window, ConditionStart start) {
  if (window <= 0) return;
  ConditionStandardiser standardiser(window);
  std::vector<std::pair<size_t, std::vector<float>>> warming;  // Index and raw vector.
  for (size_t i = 0; i < images->size(); ++i) {
    if (!images->valid[i]) continue;
    std::vector<float> raw = std::move(images->descriptors[i].global);
    images->descriptors[i].global = standardiser.apply(raw);
    if (standardiser.warmingUp()) {
      if (start == ConditionStart::kStored) warming.emplace_back(i, std::move(raw));
    } else {
      for (auto& [index, held] : warming) {
        images->descriptors[index].global = standardiser.standardise(held);
      }
      warming.clear();
    }
  }
}

cv::Mat readImage(const std::string& path, bool colour, int width) {
  cv::Mat image = cv::imread(path, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
  if (image.empty() || width <= 0 || width == image.cols) return image;
  const int height = std::max(
      1, static_cast<int>(std::lround(static_cast<double>(image.rows) * width / image.cols)));
  cv::Mat scaled;
  cv::resize(image, scaled, cv::Size(width, height), 0.0, 0.0,
             width < image.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
  return scaled;
}

DescribedImages describeImageFiles(const std::vector<std::string>& paths,
                                   const DescriptorExtractor& extractor, const Progress& progress,
                                   int width) {
  DescribedImages result = describeImages(
      paths.size(),
      [&paths, &extractor, width](size_t i) {
        return readImage(paths[i], extractor.wantsColour(), width);
      },
      extractor, progress);
  for (std::string& entry : result.undecodable) entry = paths[std::stoul(entry)];
  return result;
}

Evaluation evaluateTraversals(const DescribedImages& database, const DescribedImages& queries,
                              const GroundTruth& truth, const DescriptorExtractor& extractor,
                              const MatchingOptions& options, const Progress& progress) {
  if (truth.rows() != queries.size() || truth.cols() != database.size()) {
    throw GroundTruthError("ground truth is " + std::to_string(truth.rows()) + " x " +
                           std::to_string(truth.cols()) + " but there are " +
                           std::to_string(queries.size()) + " queries and " +
                           std::to_string(database.size()) + " database images");
  }
  SimilarityGrid grid(queries.size(), database.size(), options.matrix_size);
  DatabaseSearch search(database, extractor, options);
  search.growTo(database.size());
  std::vector<QueryOutcome> outcomes;
  std::vector<double> query_ms;
  for (size_t q = 0; q < queries.size(); ++q) {
    if (!queries.valid[q]) continue;
    drawQuery(q, queries.descriptors[q], database, database.size(), extractor, &grid);
    const auto start = Clock::now();
    outcomes.push_back(
        matchQuery(q, queries.descriptors[q], database, database.size(), search, truth, extractor));
    query_ms.push_back(millisecondsSince(start));
    if (progress) progress(q + 1, queries.size());
  }
  return summarise(extractor.name(), std::move(outcomes), std::move(query_ms), database, &queries,
                   &grid);
}

Evaluation evaluateSequence(const DescribedImages& images, const GroundTruth& truth,
                            const DescriptorExtractor& extractor, const MatchingOptions& options,
                            const Progress& progress) {
  if (truth.rows() != images.size() || truth.cols() != images.size()) {
    throw GroundTruthError("ground truth is " + std::to_string(truth.rows()) + " x " +
                           std::to_string(truth.cols()) + " but the sequence has " +
                           std::to_string(images.size()) + " images");
  }
  SimilarityGrid grid(images.size(), images.size(), options.matrix_size);
  DatabaseSearch search(images, extractor, options);
  std::vector<QueryOutcome> outcomes;
  std::vector<double> query_ms;
  for (size_t i = 0; i < images.size(); ++i) {
    if (!images.valid[i]) continue;
    const size_t end =
        static_cast<size_t>(std::max(0L, static_cast<long>(i) - options.exclude_recent));
    search.growTo(end);
    drawQuery(i, images.descriptors[i], images, end, extractor, &grid);
    const auto start = Clock::now();
    outcomes.push_back(matchQuery(i, images.descriptors[i], images, end, search, truth, extractor));
    query_ms.push_back(millisecondsSince(start));
    if (progress) progress(i + 1, images.size());
  }
  return summarise(extractor.name(), std::move(outcomes), std::move(query_ms), images, nullptr,
                   &grid);
}

cv::Mat groundTruthPicture(const GroundTruth& truth, int matrix_size) {
  const int rows = static_cast<int>(std::min<size_t>(truth.rows(), matrix_size));
  const int cols = static_cast<int>(std::min<size_t>(truth.cols(), matrix_size));
  cv::Mat picture(rows, cols, CV_8UC1, cv::Scalar(0));
  for (size_t r = 0; r < truth.rows(); ++r) {
    for (const uint32_t c : truth.positives(r)) {
      picture.at<uchar>(static_cast<int>(r * rows / truth.rows()),
                        static_cast<int>(c * cols / truth.cols())) = 255;
    }
  }
  return picture;
}

}  // namespace eval
}  // namespace landmark_loop_closure
